// Contact sheet and Markdown report of a headless run.
#include "headless_report.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <utility>
#include <vector>

#include "gauss/engine/image_io.h"

namespace gauss::view {

namespace fs = std::filesystem;

Status write_contact_sheet(const fs::path& frames_dir, const fs::path& out, std::uint32_t columns, std::uint32_t shrink,
                           std::uint32_t max_tiles) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(frames_dir, ec)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() == ".png" && name.find("_right") == std::string::npos) files.push_back(e.path());
  }
  if (ec) return Error{"contact sheet: cannot list " + frames_dir.string() + ": " + ec.message()};
  if (files.empty()) return Error{"contact sheet: no frames in " + frames_dir.string()};
  std::sort(files.begin(), files.end());
  if (files.size() > max_tiles) {
    std::vector<fs::path> picked;
    for (std::uint32_t i = 0; i < max_tiles; ++i) picked.push_back(files[i * (files.size() - 1) / (max_tiles - 1)]);
    files = std::move(picked);
  }
  ImageRGBA8 sheet;
  std::uint32_t tile_w = 0, tile_h = 0;
  const auto n = static_cast<std::uint32_t>(files.size());
  const std::uint32_t cols = std::min(columns, n), rows = (n + cols - 1) / cols;
  for (std::uint32_t k = 0; k < n; ++k) {
    auto img = read_png_rgba8(files[k]);
    if (!img) return img.error();
    if (k == 0) {
      tile_w = std::max(1u, img->width / shrink);
      tile_h = std::max(1u, img->height / shrink);
      sheet.width = cols * tile_w;
      sheet.height = rows * tile_h;
      sheet.pixels.assign(std::size_t{sheet.width} * sheet.height * 4, 40);
    }
    const std::uint32_t ox = (k % cols) * tile_w, oy = (k / cols) * tile_h;
    for (std::uint32_t y = 0; y < tile_h; ++y)
      for (std::uint32_t x = 0; x < tile_w; ++x) {
        const std::uint32_t sx = std::min(img->width - 1, x * shrink), sy = std::min(img->height - 1, y * shrink);
        const std::uint8_t* src = &img->pixels[(std::size_t{sy} * img->width + sx) * 4];
        std::uint8_t* dst = &sheet.pixels[(std::size_t{oy + y} * sheet.width + ox + x) * 4];
        std::copy(src, src + 4, dst);
      }
  }
  return write_png(out, sheet);
}

Status write_report(const fs::path& out, const nlohmann::json& s) {
  std::ofstream md(out);
  if (!md) return Error{"cannot write " + out.string()};
  auto num = [](const nlohmann::json& j, int digits) {
    if (!j.is_number()) return std::string("n/a");
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", digits, j.get<double>());
    return std::string(b);
  };
  md << "# gauss-view headless run\n\n";
  md << "- source: " << s.value("source", "") << "\n";
  md << "- frames: " << s.value("frames", 0) << " (" << s.value("path_frames", 0) << " on the path, "
     << s.value("preroll_frames", 0) << " while the stream started) in " << num(s["wall_s"], 1)
     << " s of wall time; "
     << (s.value("settled", false) ? "the stream had settled at the end (nothing pending, no edits for the quiet time)"
                                   : "the stream had NOT settled within the settle time")
     << "\n";
  if (const auto it = s.find("default_camera"); it != s.end() && it->is_object() && it->value("host_view", false)) {
    const auto& c = *it;
    md << "- camera: the host's view of its scene, " << (c.value("inside", false) ? "inside" : "outside") << " the box "
       << c["bounds"]["lo"].dump() << " .. " << c["bounds"]["hi"].dump() << ", from " << c["eye"].dump() << " toward "
       << c["target"].dump() << ", up " << c["up"].dump() << " (" << c.value("up_from", "") << ")\n";
  } else if (it != s.end() && it->is_object()) {
    const auto& c = *it;
    md << "- camera: the scene's default camera, framing the box " << c["bounds"]["lo"].dump() << " .. "
       << c["bounds"]["hi"].dump() << (c.value("opacity_weighted", false) ? " (opacity-weighted" : " (counted")
       << " 2nd..98th percentiles) from " << c["eye"].dump() << ", up " << c["up"].dump() << " ("
       << c.value("up_from", "") << ")\n";
  }
  md << "- resident Gaussians: " << s.value("resident", 0);
  if (s.contains("capacity")) md << " of M = " << s["capacity"].get<std::uint64_t>();
  md << "\n";
  if (s.contains("query")) {
    const auto& q = s["query"];
    md << "\n## Query\n\n";
    const double capacity = s.value("capacity", 0.0);
    auto held = [&](const nlohmann::json& state) {
      const double rho = state["rho"].is_number() ? state["rho"].get<double>() : 0.0;
      md << "targets " << state["targets"].dump() << " (rho " << num(state["rho"], 2) << ", reserve floor(rho M) = "
         << static_cast<std::uint64_t>(rho * capacity) << "): " << state.value("target_resident", 0)
         << " resident, share of M " << num(state["share"], 3) << "; they hold " << state.value("target_members", 0)
         << " Gaussians on the host\n";
    };
    if (s.contains("queries_at_clear"))
      for (const auto& state : s["queries_at_clear"]) {
        md << "- just before a clear: ";
        held(state);
      }
    if (q.value("active", false)) {
      md << "- at the end: ";
      held(q);
    } else {
      md << "- no query active at the end\n";
    }
    if (s.contains("query_latency_s") && !s["query_latency_s"].empty()) {
      // What each stage is: "converged" is the published set, "highlight" a drawn frame, so
      // with frames in flight the second can come after the first.
      md << "- seconds from sending a query to: targets known (the host's answer), highlight (the "
            "first frame drawn with the tint), first additional content (more of the targets published), "
            "converged (every target Gaussian the budget wants published; drawn a frame or two later)\n";
      const std::pair<const char*, const char*> labels[] = {{"target", "targets known"},
                                                            {"highlight", "highlight"},
                                                            {"first_additional", "first additional content"},
                                                            {"converged", "converged"}};
      for (const auto& [id, stages] : s["query_latency_s"].items()) {
        md << "- query " << id << ":";
        // In the order they happened (a JSON object lists its keys alphabetically).
        std::vector<std::pair<double, const char*>> happened;
        for (const auto& [key, label] : labels)
          if (stages.contains(key) && stages[key].is_number()) happened.emplace_back(stages[key].get<double>(), label);
        std::stable_sort(happened.begin(), happened.end(),
                         [](const auto& a, const auto& b) { return a.first < b.first; });
        const char* sep = " ";
        for (const auto& [t, label] : happened) {
          md << sep << label << " " << num(t, 2) << " s";
          sep = "; ";
        }
        if (stages.empty()) md << " no stage recorded under this id (a query re-sent after a reconnect takes a new id)";
        // Converged without more of the targets published (ClientState::track_query): the
        // stage is not missing, there was nothing to add.
        if (stages.contains("converged") && !stages.contains("first_additional"))
          md << "; no additional content: every target Gaussian the budget wanted was resident already";
        md << "\n";
      }
    }
  }
  // Said in the report: on lavapipe the fence wait inside cpu_ms is the rendering itself, and
  // its high percentiles otherwise read as display-thread spikes.
  md << "\n## Frame time (ms)\n\ncpu_ms: the display thread's wall time per frame, including its wait for "
        "frame k - N (N frames in flight) to finish on the device; on a CPU Vulkan device such as lavapipe that "
        "wait is the rendering itself. gpu_ms: the device's time for the frame.\n\n| | p50 | p95 | p99 |\n|---|---|---|---|\n";
  for (const char* k : {"cpu_ms", "gpu_ms"})
    if (s.contains(k))
      md << "| " << k << " | " << num(s[k]["p50"], 1) << " | " << num(s[k]["p95"], 1) << " | "
         << num(s[k]["p99"], 1) << " |\n";
  if (s.contains("gpu_pass_ms_p50")) {
    md << "\nGPU ms per pass (view 0, median over frames):";
    for (const char* pass : kGpuPasses)
      if (s["gpu_pass_ms_p50"].contains(pass)) md << " " << pass << " " << num(s["gpu_pass_ms_p50"][pass], 1) << ";";
    md << "\n";
  }
  return Ok{};
}

}  // namespace gauss::view
