// gauss-view: the desktop client (windowed with ImGui panels, or --headless), or a plain
// viewer of a scene file. See options.cpp for the command line.
#include <cstdio>
#include <cstdlib>

#include "gauss/render/vk_context.h"
#include "headless.h"
#include "options.h"
#include "windowed.h"

int main(int argc, char** argv) {
  gauss::view::ViewOptions opts;
  if (auto rc = gauss::view::parse_options(argc, argv, opts)) return *rc;
  if (!opts.headless) return gauss::view::run_windowed(opts);
  gauss::vk::ContextCreateInfo ci;
  ci.app_name = "gauss-view";
  ci.device_override = opts.device;
  auto context = gauss::vk::Context::create(ci);
  if (!context) {
    std::fprintf(stderr, "gauss-view: %s\n", context.message().c_str());
    return 1;
  }
  const int rc = gauss::view::run_headless(opts, **context);
  if ((*context)->validation_error_count() > 0) {
    std::fprintf(stderr, "gauss-view: %llu Vulkan validation errors\n",
                 static_cast<unsigned long long>((*context)->validation_error_count()));
    return rc == 0 ? 1 : rc;
  }
  return rc;
}
