// mrptBridge(): loads libdbacov_mrpt.so on first use (bridge.h). The library is the one next to
// the library that holds this function (the build's lib/ directory, or wherever both are
// installed); only when no such file exists is the loader's default search path tried.
#include <dlfcn.h>
#include <sys/stat.h>

#include <atomic>
#include <string>

#include "dbacov/core/errors.h"
#include "dbacov/mrpt/bridge.h"

namespace dbacov::mrpt_bridge {
namespace {

constexpr const char* kLibrary = "libdbacov_mrpt.so";
constexpr const char* kEntry = "dbacov_mrpt_bridge_v1";
std::atomic<bool> loaded{false};

std::string ownDirectory() {
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&mrptBridge), &info) == 0 || !info.dli_fname) return "";
  const std::string self = info.dli_fname;
  const auto slash = self.rfind('/');
  return slash == std::string::npos ? "" : self.substr(0, slash + 1);
}

const Bridge* load() {
  // A library next to this one is the one built with it: a failure to load it is reported as it
  // is, not hidden by a stale copy found elsewhere on the search path.
  const std::string beside = ownDirectory() + kLibrary;
  struct stat st {};
  const std::string path = ::stat(beside.c_str(), &st) == 0 ? beside : kLibrary;
  // RTLD_GLOBAL: MRPT's class registry and the typeinfo of exceptions are shared with the process.
  void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_GLOBAL);
  if (!handle)
    throw InputError("cannot load the MRPT bridge " + path +
                     " (needed for rawlogs, pose graphs and scenes): " + ::dlerror());
  using Entry = const Bridge* (*)();
  auto entry = reinterpret_cast<Entry>(::dlsym(handle, kEntry));
  if (!entry) {
    ::dlclose(handle);
    throw InputError("cannot load the MRPT bridge " + path + ": it has no " + kEntry +
                     " (a library of another dbacov version?)");
  }
  return entry();
}

}  // namespace

const Bridge& mrptBridge() {
  // A function-local static is initialized once, thread-safely; a load that throws is retried by
  // the next call. After that, calls cost no lock.
  static const Bridge* const bridge = load();
  loaded = true;
  return *bridge;
}

bool mrptBridgeLoaded() {
  return loaded;
}

}  // namespace dbacov::mrpt_bridge
