#include "codecs.h"

#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>

namespace odocal::media::internal {
namespace {

constexpr const char* kPluginName = "libodocal_media_codecs.so";

// Where to look: $ODOCAL_CODECS_PLUGIN alone when it is set; else beside the
// binary (an odocal copied elsewhere with its plugin), then where this build
// put it.
std::vector<std::string> Candidates() {
  if (const char* env = std::getenv("ODOCAL_CODECS_PLUGIN"); env && *env) return {env};
  std::vector<std::string> paths;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) paths.push_back((exe.parent_path() / kPluginName).string());
  paths.emplace_back(ODOCAL_MEDIA_CODECS_PATH);
  return paths;
}

}  // namespace

const Codecs* LoadCodecs(std::string* error) {
  static std::once_flag once;
  static const Codecs* codecs = nullptr;
  static std::string why;
  std::call_once(once, [] {
    std::string tried;
    const auto failed = [&tried](const std::string& reason) { tried += (tried.empty() ? "" : "; ") + reason; };
    for (const std::string& path : Candidates()) {
      if (!std::filesystem::exists(path)) {
        failed(path + ": no such file");
        continue;
      }
      // Never closed: the codecs' objects live as long as the process.
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) {
        failed(dlerror());  // names the file
        continue;
      }
      using Entry = const Codecs* (*)();
      auto entry = reinterpret_cast<Entry>(dlsym(handle, "odocal_media_codecs_v1"));
      if (!entry) {
        failed(path + ": not odocal's codec plugin");
        continue;
      }
      codecs = entry();
      return;
    }
    why = "the image and video codecs cannot be loaded (" + tried + ")";
    // Said once here as well: a caller that only sees an empty image would
    // otherwise blame the file.
    std::fprintf(stderr, "odocal: %s\n", why.c_str());
  });
  if (!codecs && error) *error = why;
  return codecs;
}

}  // namespace odocal::media::internal
