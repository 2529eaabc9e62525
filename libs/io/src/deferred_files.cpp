// DeferredFiles: an unnamed spool file, then one AtomicOutputFile per queued file. See the header.
#include "dbacov/io/deferred_files.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <optional>
#include <stdexcept>

#include "dbacov/io/atomic_file.h"

namespace dbacov::io {

DeferredFiles::DeferredFiles(const std::string& spool_dir)
    : dir_(spool_dir.empty() ? "." : spool_dir) {
  fd_ = openScratchFile(dir_);
  if (fd_ < 0)
    throw InputError(dir_ + ": cannot create a temporary spool file: " + std::strerror(errno));
}

DeferredFiles::~DeferredFiles() {
  if (fd_ >= 0) ::close(fd_);
}

void DeferredFiles::add(const std::string& path, const void* data, std::size_t size) {
  if (committed_) throw std::logic_error("DeferredFiles::add: " + path + ": already committed");
  const char* p = static_cast<const char*>(data);
  const Extent extent{end_, size};
  for (std::size_t done = 0; done < size;) {
    const ssize_t n =
        ::pwrite(fd_, p + done, std::min<std::size_t>(size - done, std::size_t{1} << 30),
                 static_cast<off_t>(end_ + done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : EIO;
      throw InputError(path + ": cannot queue the output in a spool file in '" + dir_ +
                       "': " + std::strerror(error));
    }
    done += static_cast<std::size_t>(n);
  }
  end_ += size;
  if (files_.insert_or_assign(path, extent).second) order_.push_back(path);
}

void DeferredFiles::commit() {
  if (committed_) throw std::logic_error("DeferredFiles::commit: already committed");
  committed_ = true;
  // Every file is prepared first (data written and fsync'ed), then all are renamed together
  // (CommitGroup): a kill in the commit leaves the previous files, except inside the rename loop.
  std::optional<CommitGroup> local;
  if (!CommitGroup::active()) local.emplace();
  std::vector<char> buffer;
  std::string first_error;
  std::size_t failures = 0;
  for (const std::string& path : order_) {
    try {
      const Extent e = files_.at(path);
      buffer.resize(static_cast<std::size_t>(e.size));
      for (std::size_t done = 0; done < buffer.size();) {
        const ssize_t n = ::pread(fd_, buffer.data() + done, buffer.size() - done,
                                  static_cast<off_t>(e.offset + done));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
          const int error = n < 0 ? errno : EIO;
          throw InputError(path + ": cannot read the queued output back from the spool file: " +
                           std::strerror(error));
        }
        done += static_cast<std::size_t>(n);
      }
      AtomicOutputFile out(path);
      out.write(buffer.data(), buffer.size());
      out.commit();
    } catch (const InputError& e) {  // the other files are still written
      if (failures++ == 0) first_error = e.what();
    }
  }
  if (local) {
    try {
      local->publish();
    } catch (const InputError& e) {
      if (failures++ == 0) first_error = e.what();
    }
  }
  if (failures)
    throw InputError(first_error + (failures > 1 ? " (and " + std::to_string(failures - 1) +
                                                       " more files not written)"
                                                 : std::string()));
}

}  // namespace dbacov::io
