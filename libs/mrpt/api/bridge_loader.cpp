// mrptBridge(): loads libdbacov_mrpt.so on first use (bridge.h). The library is looked for next to
// the library that holds this function (the build's lib/ directory, or wherever both are
// installed), then on the loader's default path.
#include <dlfcn.h>

#include <atomic>
#include <mutex>
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
  std::string path = ownDirectory() + kLibrary;
  // RTLD_GLOBAL: MRPT's class registry and the typeinfo of exceptions are shared with the process.
  void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_GLOBAL);
  std::string why = handle ? "" : ::dlerror();
  if (!handle) {
    handle = ::dlopen(kLibrary, RTLD_NOW | RTLD_GLOBAL);
    if (handle) path = kLibrary;
  }
  if (!handle)
    throw InputError("cannot load the MRPT bridge " + path +
                     " (needed for rawlogs, pose graphs "
                     "and scenes): " +
                     why);
  using Entry = const Bridge* (*)();
  auto entry = reinterpret_cast<Entry>(::dlsym(handle, kEntry));
  if (!entry)
    throw InputError("cannot load the MRPT bridge " + path + ": it has no " + kEntry +
                     " (a library of another dbacov version?)");
  return entry();
}

}  // namespace

const Bridge& mrptBridge() {
  static std::mutex mutex;
  static const Bridge* bridge = nullptr;
  std::lock_guard<std::mutex> lock(mutex);
  if (!bridge) {
    bridge = load();
    loaded = true;
  }
  return *bridge;
}

bool mrptBridgeLoaded() {
  return loaded;
}

}  // namespace dbacov::mrpt_bridge
