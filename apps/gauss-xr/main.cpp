// gauss-xr: the headset client (see headset_loop.h).
#include "headset_loop.h"
#include "options.h"

int main(int argc, char** argv) {
  gauss::xr_app::XrOptions options;
  if (auto rc = gauss::xr_app::parse_options(argc, argv, options)) return *rc;
  return gauss::xr_app::run_headset(options);
}
