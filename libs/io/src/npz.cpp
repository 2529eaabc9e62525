// NpzReader / NpzWriter on libzip. Every libzip handle is owned by a std::unique_ptr.
#include "dbacov/io/npz.h"

#include <zip.h>

#include <algorithm>
#include <ctime>
#include <exception>
#include <filesystem>
#include <optional>
#include <set>
#include <stdexcept>

#include "dbacov/core/parallel.h"
#include "dbacov/io/atomic_file.h"
#include "dbacov/io/memory_budget.h"
#include "member_inflate.h"
#include "npy_internal.h"

namespace dbacov::io {
namespace {

struct ZipDiscard {
  void operator()(zip_t* z) const { zip_discard(z); }
};
struct ZipFileClose {
  void operator()(zip_file_t* f) const { zip_fclose(f); }
};
struct ZipSourceFree {
  void operator()(zip_source_t* s) const { zip_source_free(s); }
};
struct ZipErrorFini {
  void operator()(zip_error_t* e) const { zip_error_fini(e); }
};
using ZipPtr = std::unique_ptr<zip_t, ZipDiscard>;
using ZipFilePtr = std::unique_ptr<zip_file_t, ZipFileClose>;
using ZipSourcePtr = std::unique_ptr<zip_source_t, ZipSourceFree>;

constexpr const char* kSuffix = ".npy";
constexpr std::uint64_t kDeflateMaxRatio = 1032;  // deflate cannot expand more than this

/// libzip's message for an error code from zip_open.
std::string zipErrorString(int code) {
  zip_error_t e;
  zip_error_init_with_code(&e, code);
  std::unique_ptr<zip_error_t, ZipErrorFini> guard(&e);
  return zip_error_strerror(&e);
}

/// 1980-01-01 00:00 local time: the DOS epoch that NumPy's zipfile members carry.
std::time_t dosEpoch() {
  std::tm t{};
  t.tm_year = 80;
  t.tm_mday = 1;
  t.tm_isdst = -1;
  return std::mktime(&t);
}

}  // namespace

struct NpzReader::Impl {
  std::string path;
  std::uint64_t max_entry_bytes = 0;
  std::uint64_t file_size = 0;
  std::vector<unsigned char> bytes;  ///< the archive, when read from memory (libzip borrows it)
  ZipPtr zip;
};

NpzReader::NpzReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {
  checkUniqueMembers();
}

void NpzReader::checkUniqueMembers() const {
  // Two members of one name: libzip finds the first, NumPy the last. Refuse rather than guess.
  std::set<std::string> seen;
  const zip_int64_t n = zip_get_num_entries(impl_->zip.get(), 0);
  for (zip_int64_t i = 0; i < n; ++i) {
    const char* name = zip_get_name(impl_->zip.get(), static_cast<zip_uint64_t>(i), 0);
    if (name && !seen.insert(name).second)
      throw InputError(impl_->path + ": the archive holds two members named '" + name +
                       "' (NumPy would read the last, others the first): rewrite the file with "
                       "each key once");
  }
}

NpzReader NpzReader::fromMemory(const std::string& name, std::vector<unsigned char> bytes,
                                std::uint64_t max_entry_bytes) {
  auto impl = std::make_unique<Impl>();
  impl->path = name;
  impl->max_entry_bytes = max_entry_bytes;
  impl->file_size = bytes.size();
  impl->bytes = std::move(bytes);
  zip_error_t error;
  zip_error_init(&error);
  std::unique_ptr<zip_error_t, ZipErrorFini> error_guard(&error);
  ZipSourcePtr source(zip_source_buffer_create(impl->bytes.data(), impl->bytes.size(), 0, &error));
  if (!source)
    throw InputError(name + ": cannot open as a .npz (zip) archive: " + zip_error_strerror(&error));
  impl->zip.reset(zip_open_from_source(source.get(), ZIP_RDONLY, &error));
  if (!impl->zip)
    throw InputError(name + ": cannot open as a .npz (zip) archive: " + zip_error_strerror(&error));
  static_cast<void>(source.release());  // the archive owns the source now
  return NpzReader(std::move(impl));
}

NpzReader::NpzReader(const std::string& path, std::uint64_t max_entry_bytes)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->max_entry_bytes = max_entry_bytes;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path + ": cannot open .npz archive: " +
                     (ec ? ec.message() : std::string("not a regular file")));
  impl_->file_size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path + ": cannot open .npz archive: " + ec.message());
  int code = 0;
  impl_->zip.reset(zip_open(path.c_str(), ZIP_RDONLY, &code));
  if (!impl_->zip)
    throw InputError(path + ": cannot open as a .npz (zip) archive: " + zipErrorString(code));
  checkUniqueMembers();
}

NpzReader::~NpzReader() = default;
NpzReader::NpzReader(NpzReader&&) noexcept = default;
NpzReader& NpzReader::operator=(NpzReader&&) noexcept = default;

const std::string& NpzReader::path() const {
  return impl_->path;
}

std::vector<std::string> NpzReader::keys() const {
  std::vector<std::string> keys;
  const zip_int64_t n = zip_get_num_entries(impl_->zip.get(), 0);
  for (zip_int64_t i = 0; i < n; ++i) {
    const char* name = zip_get_name(impl_->zip.get(), static_cast<zip_uint64_t>(i), 0);
    if (!name) continue;
    const std::string s(name);
    if (s.size() > 4 && s.compare(s.size() - 4, 4, kSuffix) == 0)
      keys.push_back(s.substr(0, s.size() - 4));
  }
  return keys;
}

bool NpzReader::has(const std::string& key) const {
  return zip_name_locate(impl_->zip.get(), (key + kSuffix).c_str(), 0) >= 0;
}

/// A member's raw (still compressed) bytes and what the archive records about it.
struct NpzReader::RawMember {
  std::string key;
  std::string context;     ///< "<path>: key '<key>'"
  ByteVector raw;          ///< the member's bytes as the archive holds them
  std::uint64_t size = 0;  ///< recorded uncompressed size
  std::uint32_t crc = 0;   ///< recorded CRC-32
  bool deflated = false;
};

NpzReader::RawMember NpzReader::fetch(const std::string& key) const {
  zip_t* za = impl_->zip.get();
  RawMember m;
  m.key = key;
  m.context = impl_->path + ": key '" + key + "'";
  auto fail = [&](const std::string& what) { throw InputError(m.context + ": " + what); };

  const zip_int64_t index = zip_name_locate(za, (key + kSuffix).c_str(), 0);
  if (index < 0) throw InputError(impl_->path + ": missing key '" + key + "'");
  const auto idx = static_cast<zip_uint64_t>(index);
  zip_stat_t st;
  zip_stat_init(&st);
  if (zip_stat_index(za, idx, 0, &st) != 0) fail(std::string("cannot stat: ") + zip_strerror(za));
  const zip_uint64_t need =
      ZIP_STAT_SIZE | ZIP_STAT_COMP_SIZE | ZIP_STAT_COMP_METHOD | ZIP_STAT_CRC;
  if ((st.valid & need) != need) fail("the archive does not record the member's sizes");
  if ((st.valid & ZIP_STAT_ENCRYPTION_METHOD) && st.encryption_method != ZIP_EM_NONE)
    fail("encrypted members are not supported");

  // Size checks before anything is allocated: the limit, then plausibility against the bytes
  // that are really in the archive.
  if (st.size > impl_->max_entry_bytes)
    fail("member of " + std::to_string(st.size) + " bytes exceeds the limit of " +
         std::to_string(impl_->max_entry_bytes) + " bytes");
  if (st.comp_size > impl_->file_size)
    fail("member claims " + std::to_string(st.comp_size) + " compressed bytes in a file of " +
         std::to_string(impl_->file_size) + " bytes (damaged archive)");
  if (st.comp_method == ZIP_CM_STORE) {
    if (st.size != st.comp_size)
      fail("stored member has inconsistent sizes (" + std::to_string(st.size) + " vs " +
           std::to_string(st.comp_size) + " bytes; damaged archive)");
  } else if (st.comp_method == ZIP_CM_DEFLATE) {
    if (st.size > st.comp_size * kDeflateMaxRatio + 1024)
      fail("deflated member claims " + std::to_string(st.size) + " bytes from " +
           std::to_string(st.comp_size) + " compressed bytes (damaged archive)");
  } else {
    fail("compression method " + std::to_string(st.comp_method) +
         " is not supported (expected stored or deflated, as NumPy writes)");
  }
  m.size = st.size;
  m.crc = st.crc;
  m.deflated = st.comp_method == ZIP_CM_DEFLATE;

  // The raw bytes as they are in the archive; libdeflate inflates and checks them as a whole
  // (inflateMember), which is about twice as fast as libzip's streaming zlib.
  ZipFilePtr file(zip_fopen_index(za, idx, ZIP_FL_COMPRESSED));
  if (!file) fail(std::string("cannot open member: ") + zip_strerror(za));
  m.raw.resize(static_cast<std::size_t>(st.comp_size));  // not zeroed: the reads fill it
  for (std::size_t done = 0; done < m.raw.size();) {
    const zip_int64_t got = zip_fread(file.get(), m.raw.data() + done, m.raw.size() - done);
    if (got < 0) fail(std::string("cannot read member: ") + zip_file_strerror(file.get()));
    if (got == 0) fail("cannot read member: Premature end of file");
    done += static_cast<std::size_t>(got);
  }
  return m;
}

std::optional<NpyArray> NpzReader::decode(RawMember m) {
  InflatedMember in = inflateMember(std::move(m.raw), m.size, m.crc, m.deflated);
  if (in.status != InflateStatus::Ok) return std::nullopt;
  return parseNpyBuffer(std::move(in.bytes), m.size, m.context);
}

NpyArray NpzReader::readStreaming(const std::string& key) const {
  // The damaged-member path: libzip's streaming zlib, whose messages say where the damage shows
  // first (a bad .npy header, truncated data, the CRC at the end).
  const RawMember checked = fetch(key);  // the same checks, in the same order
  zip_t* za = impl_->zip.get();
  auto fail = [&](const std::string& what) { throw InputError(checked.context + ": " + what); };
  const zip_int64_t index = zip_name_locate(za, (key + kSuffix).c_str(), 0);
  ZipFilePtr file(zip_fopen_index(za, static_cast<zip_uint64_t>(index), 0));
  if (!file) fail(std::string("cannot open member: ") + zip_strerror(za));
  NpyArray a = readNpyStream(
      checked.size,
      [&](unsigned char* dst, std::size_t n) -> std::size_t {
        const zip_int64_t got = zip_fread(file.get(), dst, n);
        if (got < 0) fail(std::string("cannot read member: ") + zip_file_strerror(file.get()));
        return static_cast<std::size_t>(got);
      },
      checked.context);
  // libdeflate refused the member but zlib did not: refuse it all the same.
  fail("cannot read member: the deflate stream or its CRC-32 is damaged");
  return a;
}

NpyArray NpzReader::read(const std::string& key) const {
  std::optional<NpyArray> a = decode(fetch(key));
  return a ? std::move(*a) : readStreaming(key);
}

void NpzReader::checkBudget(const std::vector<std::string>& keys) const {
  // The members' declared sizes, summed before anything is inflated: each may be plausible alone
  // (deflate packs a constant plane 1000:1) while together they would exhaust the memory.
  zip_t* za = impl_->zip.get();
  std::uint64_t total = 0, largest = 0;
  std::string largest_key;
  for (const std::string& key : keys) {
    const zip_int64_t index = zip_name_locate(za, (key + kSuffix).c_str(), 0);
    zip_stat_t st;
    zip_stat_init(&st);
    if (index < 0 || zip_stat_index(za, static_cast<zip_uint64_t>(index), 0, &st) != 0 ||
        !(st.valid & ZIP_STAT_SIZE))
      continue;  // fetch() reports it
    total += std::min<std::uint64_t>(st.size, std::uint64_t{1} << 62);
    if (st.size > largest) {
      largest = st.size;
      largest_key = key;
    }
  }
  const MemoryBudget budget = memoryBudget();
  if (total > budget.bytes)
    throw InputError(impl_->path + ": its arrays declare " + sizeText(total) +
                     " uncompressed (the largest, key '" + largest_key + "', " + sizeText(largest) +
                     "; the archive itself is " + sizeText(impl_->file_size) +
                     "), more than the memory budget of " + sizeText(budget.bytes) + " (" +
                     budget.source + ")");
}

std::vector<NpyArray> NpzReader::readAll(const std::vector<std::string>& keys) const {
  checkBudget(keys);
  // The archive handle is serial: fetch the raw members in order (stopping at the first failure),
  // then inflate and parse them in parallel. The first failure in key order is the one reported,
  // as a serial read() of each key would.
  std::vector<RawMember> raw;
  std::exception_ptr fetch_failure;
  for (const std::string& key : keys) {
    try {
      raw.push_back(fetch(key));
    } catch (...) {
      fetch_failure = std::current_exception();
      break;
    }
  }
  std::vector<std::optional<NpyArray>> decoded(raw.size());
  std::vector<std::exception_ptr> failures(raw.size());
  // Largest first, so that the biggest member starts at once on a free thread.
  std::vector<std::size_t> order(raw.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return raw[a].size > raw[b].size; });
  parallelFor(order.size(), [&](std::size_t o) {
    const std::size_t i = order[o];
    try {
      decoded[i] = decode(std::move(raw[i]));
    } catch (...) {
      failures[i] = std::current_exception();
    }
  });
  std::vector<NpyArray> out;
  out.reserve(keys.size());
  for (std::size_t i = 0; i < decoded.size(); ++i) {
    if (failures[i]) std::rethrow_exception(failures[i]);
    out.push_back(decoded[i] ? std::move(*decoded[i]) : readStreaming(keys[i]));
  }
  if (fetch_failure) std::rethrow_exception(fetch_failure);
  return out;
}

NpzWriter::NpzWriter(std::string path, bool compressed)
    : path_(std::move(path)), compressed_(compressed) {}

void NpzWriter::add(const std::string& key, const NpyArray& array) {
  if (committed_) throw std::logic_error("NpzWriter::add: " + path_ + " already committed");
  if (key.empty() || key.find('\0') != std::string::npos)
    throw std::invalid_argument("NpzWriter::add: invalid key for " + path_);
  const std::string name = key + kSuffix;
  for (const auto& m : members_)
    if (m.first == name)
      throw std::invalid_argument("NpzWriter::add: duplicate key '" + key + "' for " + path_);
  members_.emplace_back(name, serializeNpy(array));
}

void NpzWriter::commit() {
  if (committed_) throw std::logic_error("NpzWriter::commit: " + path_ + " already committed");
  auto fail = [&](const std::string& what) { throw InputError(path_ + ": " + what); };

  // An archive without members: libzip would delete it instead, so write the 22-byte
  // end-of-central-directory record that np.savez() writes for no arrays.
  std::vector<unsigned char> bytes = {'P', 'K', 5, 6};
  bytes.resize(22, 0);
  if (!members_.empty()) {
    zip_error_t error;
    zip_error_init(&error);
    std::unique_ptr<zip_error_t, ZipErrorFini> error_guard(&error);
    ZipSourcePtr buffer(zip_source_buffer_create(nullptr, 0, 0, &error));
    if (!buffer) fail(std::string("cannot create a zip buffer: ") + zip_error_strerror(&error));
    ZipPtr zip(zip_open_from_source(buffer.get(), ZIP_CREATE | ZIP_TRUNCATE, &error));
    if (!zip) fail(std::string("cannot create a zip archive: ") + zip_error_strerror(&error));
    zip_source_keep(buffer.get());  // `zip` owns one reference, `buffer` the other
    const std::time_t mtime = dosEpoch();
    for (const auto& [name, npy] : members_) {
      const std::string key = name.substr(0, name.size() - 4);
      zip_source_t* src = zip_source_buffer(zip.get(), npy.data(), npy.size(), 0);
      const zip_int64_t idx =
          src ? zip_file_add(zip.get(), name.c_str(), src, ZIP_FL_ENC_UTF_8) : -1;
      if (idx < 0) {
        zip_source_free(src);
        fail("key '" + key + "': cannot add to the archive: " + zip_strerror(zip.get()));
      }
      const auto i = static_cast<zip_uint64_t>(idx);
      if (zip_set_file_compression(zip.get(), i, compressed_ ? ZIP_CM_DEFLATE : ZIP_CM_STORE, 0) ||
          zip_file_set_mtime(zip.get(), i, mtime, 0))
        fail("key '" + key + "': " + zip_strerror(zip.get()));
    }
    if (zip_close(zip.get()) != 0)
      fail(std::string("cannot build the zip archive: ") + zip_strerror(zip.get()));
    static_cast<void>(zip.release());  // zip_close freed it

    // Read the finished archive back out of the buffer source.
    zip_source_t* b = buffer.get();
    auto bufferError = [&] {
      fail(std::string("cannot read back the zip buffer: ") +
           zip_error_strerror(zip_source_error(b)));
    };
    if (zip_source_open(b) != 0) bufferError();
    std::unique_ptr<zip_source_t, int (*)(zip_source_t*)> opened(b, zip_source_close);
    if (zip_source_seek(b, 0, SEEK_END) != 0) bufferError();
    const zip_int64_t size = zip_source_tell(b);
    if (size <= 0 || zip_source_seek(b, 0, SEEK_SET) != 0) bufferError();
    bytes.assign(static_cast<std::size_t>(size), 0);
    for (std::size_t done = 0; done < bytes.size();) {
      const zip_int64_t got = zip_source_read(b, bytes.data() + done, bytes.size() - done);
      if (got <= 0) bufferError();
      done += static_cast<std::size_t>(got);
    }
  }
  AtomicOutputFile out(path_);
  out.write(bytes.data(), bytes.size());
  out.commit();
  committed_ = true;
}

}  // namespace dbacov::io
