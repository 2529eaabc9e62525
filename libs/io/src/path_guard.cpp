// OutputPlan: inputs and outputs compared by file identity. See path_guard.h.
#include "dbacov/io/path_guard.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>

namespace dbacov::io {
namespace {

namespace fs = std::filesystem;

/// What a path designates: an existing file (device + inode), or the place where a new file
/// would be created (resolved location).
struct Identity {
  bool exists = false;
  bool char_device = false;
  bool directory = false;
  dev_t dev = 0;
  ino_t ino = 0;
  std::string location;
};

Identity identify(const std::string& path) {
  Identity id;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    id.exists = true;
    id.char_device = S_ISCHR(st.st_mode);
    id.directory = S_ISDIR(st.st_mode);
    id.dev = st.st_dev;
    id.ino = st.st_ino;
    return id;
  }
  std::error_code ec;
  const fs::path target = fs::absolute(resolveOutputTarget(path), ec);
  fs::path loc = ec ? fs::path(path) : fs::weakly_canonical(target, ec);
  id.location = (ec ? target.lexically_normal() : loc).string();
  return id;
}

bool same(const Identity& a, const Identity& b) {
  if (a.exists != b.exists) return false;
  return a.exists ? a.dev == b.dev && a.ino == b.ino : a.location == b.location;
}

std::string describe(const std::string& option, const std::string& path) {
  return option + " " + path;
}

/// Throws InputError when a component of `path` is longer than its file system allows (or the
/// whole path longer than PATH_MAX): caught here, before the work, not at the commit after it.
void checkNameLengths(const std::string& option, const std::string& path) {
  if (path.size() >= PATH_MAX)
    throw InputError(describe(option, path.substr(0, 60) + "...") + ": the path is " +
                     std::to_string(path.size()) + " bytes long, more than the " +
                     std::to_string(PATH_MAX - 1) + " the system allows: choose a shorter path");
  std::string parent = ".";
  std::size_t begin = 0;
  if (!path.empty() && path[0] == '/') {
    parent = "/";
    begin = 1;
  }
  while (begin < path.size()) {
    std::size_t end = path.find('/', begin);
    if (end == std::string::npos) end = path.size();
    const std::size_t length = end - begin;
    if (length > 0) {
      // The directory may not exist yet (the run's error is then another); 255 is Linux's NAME_MAX
      // on every common file system.
      long max = ::pathconf(parent.c_str(), _PC_NAME_MAX);
      if (max <= 0) max = NAME_MAX;
      if (length > static_cast<std::size_t>(max))
        throw InputError(describe(option, path) + ": the name '" + path.substr(begin, 40) +
                         "...' is " + std::to_string(length) + " bytes long, more than the " +
                         std::to_string(max) + " its file system allows: choose a shorter name");
    }
    parent = path.substr(0, end);
    if (parent.empty()) parent = "/";
    begin = end + 1;
  }
}

}  // namespace

std::string resolveOutputTarget(const std::string& path) {
  std::string p = path;
  for (int hops = 0;; ++hops) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p;
    if (hops == 40) throw InputError(path + ": too many levels of symbolic links (more than 40)");
    std::string link(4096, '\0');
    const ssize_t n = ::readlink(p.c_str(), link.data(), link.size());
    if (n < 0 || static_cast<std::size_t>(n) >= link.size())
      throw InputError(path + ": cannot read the symbolic link " + p + ": " +
                       std::strerror(n < 0 ? errno : ENAMETOOLONG));
    link.resize(static_cast<std::size_t>(n));
    if (link.empty() || link[0] != '/') {
      const std::size_t slash = p.rfind('/');
      if (slash != std::string::npos) link = p.substr(0, slash + 1) + link;
    }
    p = link;
  }
}

void OutputPlan::input(const std::string& path, const std::string& option,
                       const std::string& dir_extension) {
  if (path.empty()) return;
  std::error_code ec;
  if (!dir_extension.empty() && fs::is_directory(path, ec)) {
    for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec))
      if (it->path().extension() == dir_extension)
        inputs_.push_back({it->path().string(), option + " " + path + ":"});
    return;
  }
  inputs_.push_back({path, option});
}

void OutputPlan::output(const std::string& path, const std::string& option) {
  if (!path.empty()) outputs_.push_back({path, option});
}

void OutputPlan::outputDirectory(const std::string& path, const std::string& option) {
  if (!path.empty()) output_dirs_.push_back({path, option});
}

void OutputPlan::check() const {
  for (const Entry& o : outputs_) checkNameLengths(o.option, o.path);
  for (const Entry& d : output_dirs_) checkNameLengths(d.option, d.path);
  std::vector<Identity> in;
  for (const Entry& e : inputs_) in.push_back(identify(e.path));
  auto clashWithInput = [&](const Entry& o, const Identity& id) {
    for (std::size_t i = 0; i < inputs_.size(); ++i)
      if (in[i].exists && !in[i].directory && !in[i].char_device && same(id, in[i])) {
        // An input listed from a directory is described as "-i DIR: FILE".
        const std::string input = inputs_[i].option.back() == ':'
                                      ? inputs_[i].option + " " + inputs_[i].path
                                      : describe(inputs_[i].option, inputs_[i].path);
        throw InputError(describe(o.option, o.path) + " is the input " + input +
                         " (the same file): writing it would destroy the input; choose another " +
                         "output path");
      }
  };
  for (const Entry& d : output_dirs_) clashWithInput(d, identify(d.path));
  std::vector<Identity> out;
  for (const Entry& o : outputs_) {
    const Identity id = identify(o.path);
    clashWithInput(o, id);
    if (!id.char_device)  // /dev/null and terminals take any number of outputs
      for (std::size_t j = 0; j < out.size(); ++j)
        if (same(id, out[j]))
          throw InputError(describe(o.option, o.path) + " and " +
                           describe(outputs_[j].option, outputs_[j].path) +
                           " are the same file: one output would overwrite the other; give "
                           "each output its own path");
    out.push_back(id);
  }
}

}  // namespace dbacov::io
