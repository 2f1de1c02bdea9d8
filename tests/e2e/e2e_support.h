#pragma once
// What the end-to-end tests share: reading a log, and the central check of the real
// programs: the client's final frame equals, byte for byte, the host's own render
// (gauss-render) of the very set it sent that client (gauss-host --dump-sent), from the
// client's final camera, in the client's slot order (equal depths blend in slot order).
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "child_process.h"
#include "text_file.h"
#include "gauss/engine/image_io.h"

namespace gauss::test {

namespace fs = std::filesystem;
using namespace std::chrono_literals;


// The host writes its dump of what it sent the client when it sees the client leave;
// then it is stopped. Renders that set with gauss-render from the client's final camera
// in the client's slot order and compares with the client's final frame, byte for byte.
inline void expect_client_frame_equals_host_render(ChildProcess& host, const fs::path& out, const fs::path& dump_dir,
                                                   const std::string& host_log) {
  const fs::path dump = dump_dir / "gauss-view.ply";
  const fs::path dump_mesh = dump_dir / "gauss-view.mesh.ply";
  for (int i = 0; i < 200 && !fs::exists(dump_mesh); ++i) std::this_thread::sleep_for(50ms);
  const auto host_rc = host.stop(SIGINT);
  EXPECT_EQ(host_rc.value_or(-1), 0) << read_text(out / host_log);
  ASSERT_TRUE(fs::exists(dump)) << read_text(out / host_log);
  ASSERT_TRUE(fs::exists(dump_mesh)) << read_text(out / host_log);

  ChildProcess render;
  ASSERT_TRUE(render.start({GAUSS_RENDER_EXE, "--scene", dump.string(), "--mesh", dump_mesh.string(), "--camera",
                            (out / "view" / "final_camera.json").string(), "--order",
                            (out / "view" / "final_slot_ids.json").string(), "--out", (out / "host.png").string()},
                           out / "render.log"));
  const auto render_rc = render.wait(120s);
  if (!render_rc) render.stop(SIGKILL);
  ASSERT_EQ(render_rc.value_or(-1), 0) << read_text(out / "render.log");

  auto client_img = gauss::read_png_rgba8(out / "view" / "final.png");
  auto host_img = gauss::read_png_rgba8(out / "host.png");
  ASSERT_TRUE(client_img.ok()) << client_img.message();
  ASSERT_TRUE(host_img.ok()) << host_img.message();
  ASSERT_EQ(client_img->width, host_img->width);
  ASSERT_EQ(client_img->height, host_img->height);
  std::size_t differ = 0, lit = 0;
  for (std::size_t i = 0; i + 3 < client_img->pixels.size(); i += 4) {
    for (int c = 0; c < 4; ++c)
      if (client_img->pixels[i + c] != host_img->pixels[i + c]) {
        ++differ;
        break;
      }
    if (client_img->pixels[i] + client_img->pixels[i + 1] + client_img->pixels[i + 2] > 30) ++lit;
  }
  EXPECT_EQ(differ, 0u) << "pixels differing between the client's frame and the host's render of the sent set";
  EXPECT_GT(lit, client_img->pixels.size() / 8) << "the scene is in view";
}

}  // namespace gauss::test
