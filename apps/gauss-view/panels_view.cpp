// Panels: the layout, the figures fed per frame, and the timing and view panels (see
// panels.h).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <imgui.h>

#include "panels.h"

namespace gauss::view {
namespace {

constexpr float kPanelW = 290.0f;
constexpr float kMargin = 8.0f;
// Below this window width the first-use layout starts objects, timing and view collapsed
// so that the scene stays visible between the two panel columns.
constexpr std::uint32_t kSmallWindowWidth = 1000;

// One scrolling graph, its name and last value written over it.
void plot(const char* name, const PlotHistory& h) {
  char overlay[48];
  std::snprintf(overlay, sizeof overlay, "%s %.2f ms", name, static_cast<double>(h.last()));
  ImGui::PushID(name);
  ImGui::PlotLines("##plot", h.values(), h.count(), h.offset(), overlay, 0.0f, std::max(1.0f, h.max() * 1.1f),
                   ImVec2(ImGui::GetContentRegionAvail().x, 34.0f));  // PlotLines takes no negative width
  ImGui::PopID();
}

}  // namespace

void Panels::add_frame(const client::DisplayFrameStats& stats, double interval_ms) {
  last_ = stats;
  cpu_ms_.push(stats.cpu_ms);
  frame_ms_.push(interval_ms);
}

void Panels::add_gpu(const client::GpuFrameStats& gpu) {
  // Per pass of view 0 (the left eye in stereo); the total covers every view.
  const render::SplatPassTimings& t = gpu.view[0].gpu;
  gpu_mesh_.push(t.mesh_ms);
  gpu_preprocess_.push(t.preprocess_ms + t.compact_ms);
  gpu_sorts_.push(t.depth_sort_ms + t.tile_sort_ms);
  gpu_emit_.push(t.emit_ms + t.ranges_ms);
  gpu_blend_.push(t.blend_ms);
  gpu_total_.push(gpu.total_ms);
  gpu_visible_ = gpu.view[0].visible;
}

void Panels::draw(FlyCamera& camera, std::uint32_t width, std::uint32_t height, double now_s) {
  small_window_ = width < kSmallWindowWidth;
  const float w = static_cast<float>(width);
  const float right = std::max(kMargin, w - kPanelW - kMargin);
  place(kMargin, kMargin, kPanelW, 145.0f, false);
  draw_connection(now_s);
  place(kMargin, 161.0f, kPanelW, 218.0f, false);
  draw_stream();
  place(kMargin, 387.0f, kPanelW, std::max(120.0f, static_cast<float>(height) - 395.0f), small_window_);
  draw_objects(now_s);
  place(right, kMargin, kPanelW, 370.0f, small_window_);
  draw_timing();
  place(right, small_window_ ? 34.0f : 386.0f, kPanelW, 300.0f, small_window_);
  draw_view(camera);
}

void Panels::draw_timing() {
  if (!ImGui::Begin("timing")) {
    ImGui::End();
    return;
  }
  ImGui::Text("frame %.1f ms (%.0f fps)", static_cast<double>(frame_ms_.last()),
              frame_ms_.last() > 0.0f ? 1000.0 / frame_ms_.last() : 0.0);
  plot("frame", frame_ms_);
  plot("cpu", cpu_ms_);
  ImGui::Text("gpu, view 0 (%u visible)", gpu_visible_);
  plot("mesh", gpu_mesh_);
  plot("preprocess", gpu_preprocess_);
  plot("sorts", gpu_sorts_);
  plot("emit", gpu_emit_);
  plot("blend", gpu_blend_);
  plot("total", gpu_total_);
  ImGui::End();
}

void Panels::draw_view(FlyCamera& camera) {
  if (!ImGui::Begin("view")) {
    ImGui::End();
    return;
  }
  const FlyPose& p = camera.pose();
  ImGui::Text("at %.2f %.2f %.2f  yaw %.0f  pitch %.0f", p.position.x, p.position.y, p.position.z,
              p.yaw * 180.0 / 3.14159265358979323846, p.pitch * 180.0 / 3.14159265358979323846);
  float speed = static_cast<float>(camera.speed());
  ImGui::SetNextItemWidth(150.0f);
  if (ImGui::SliderFloat("speed", &speed, static_cast<float>(FlyCamera::kMinSpeed),
                         static_cast<float>(FlyCamera::kMaxSpeed), "%.2f m/s", ImGuiSliderFlags_Logarithmic)) {
    camera.set_speed(speed);
  }

  ImGui::BeginDisabled(rt_ == nullptr);
  if (ImGui::Checkbox("highlight query", &settings_.highlight) && rt_ != nullptr) rt_->set_highlight(settings_.highlight);
  if (ImGui::Checkbox("edit tints", &settings_.tint_edits) && rt_ != nullptr) rt_->set_tint_edits(settings_.tint_edits);
  ImGui::EndDisabled();
  ImGui::Checkbox("stereo preview", &settings_.stereo);
  float ipd_mm = static_cast<float>(settings_.ipd * 1000.0);
  ImGui::SetNextItemWidth(150.0f);
  if (ImGui::SliderFloat("IPD", &ipd_mm, 0.0f, 200.0f, "%.0f mm")) settings_.ipd = ipd_mm / 1000.0;

  if (ImGui::Button("save viewpoint")) {
    viewpoints_.push_back(SavedViewpoint{"view " + std::to_string(next_viewpoint_++), camera.pose()});
  }
  std::optional<std::size_t> erase;
  for (std::size_t i = 0; i < viewpoints_.size(); ++i) {
    const SavedViewpoint& v = viewpoints_[i];
    ImGui::PushID(static_cast<int>(i));
    if (ImGui::SmallButton("go")) camera.set_pose(v.pose);
    ImGui::SameLine();
    if (ImGui::SmallButton("x")) erase = i;
    ImGui::SameLine();
    ImGui::Text("%s  (%.1f %.1f %.1f)", v.name.c_str(), v.pose.position.x, v.pose.position.y, v.pose.position.z);
    ImGui::PopID();
  }
  if (erase) viewpoints_.erase(viewpoints_.begin() + static_cast<std::ptrdiff_t>(*erase));
  ImGui::TextDisabled("WASD move, E/Q up/down, Shift fast,");
  ImGui::TextDisabled("right mouse look, wheel speed");
  ImGui::End();
}

}  // namespace gauss::view
