// Panels: the layout, the figures fed per frame, and the timing and view panels (see
// panels.h).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <imgui.h>
#include <glm/geometric.hpp>

#include "panels.h"

namespace gauss::view {
namespace {

constexpr float kPanelW = 290.0f;
constexpr float kMargin = 8.0f;
// A collapsed panel's title bar and the gap to the next (ImGui's default font and padding).
constexpr float kTitleStep = 26.0f;

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

void Panels::draw(FlyCamera& camera, bool orbit, std::uint32_t width, std::uint32_t height, double now_s) {
  // At 640x480 the expanded left column alone covered half the scene: a small window starts
  // with every panel collapsed, its title bars stacked at the top of each column.
  small_window_ = width < kSmallWindowWidth;
  const float w = static_cast<float>(width), h = static_cast<float>(height);
  const float right = std::max(kMargin, w - kPanelW - kMargin);
  // Top of panel `i` of a column: collapsed, one title bar below the other; expanded, the
  // given y of the large layout.
  const auto top = [&](int i, float expanded_y) { return small_window_ ? kMargin + i * kTitleStep : expanded_y; };
  place(kMargin, top(0, kMargin), kPanelW, 145.0f, small_window_);
  draw_connection(now_s);
  place(kMargin, top(1, 161.0f), kPanelW, 218.0f, small_window_);
  draw_stream();
  // A stream's scene panel holds one hint and a local scene has no objects to query: the one
  // without content starts collapsed and the other takes the column's rest (at 1200x760 the
  // objects panel of a stream ended below the window, its query buttons cut off).
  const bool streamed = source_->summary() == nullptr;
  place(kMargin, top(2, 387.0f), kPanelW, 270.0f, small_window_ || streamed);
  draw_scene();
  const float objects_y = streamed ? 387.0f + kTitleStep : 665.0f;
  place(kMargin, top(3, objects_y), kPanelW, std::max(120.0f, h - objects_y - kMargin), small_window_ || !streamed);
  draw_objects(now_s);
  place(right, top(0, kMargin), kPanelW, 370.0f, small_window_);
  draw_timing();
  // The view panel takes the rest of the column (it scrolls when that is too short).
  place(right, top(1, 386.0f), kPanelW, std::max(300.0f, h - 394.0f), small_window_);
  draw_view(camera, orbit);
  draw_notices(width, height, now_s);
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

void Panels::draw_view(FlyCamera& camera, bool orbit) {
  if (!ImGui::Begin("view")) {
    ImGui::End();
    return;
  }
  const FlyPose& p = camera.pose();
  ImGui::Text("at %.2f %.2f %.2f", p.position.x, p.position.y, p.position.z);
  ImGui::Text("yaw %.0f  pitch %.0f  up %s",
              p.yaw * 180.0 / 3.14159265358979323846, p.pitch * 180.0 / 3.14159265358979323846,
              up_label(camera.up()).c_str());
  draw_framing(camera);
  if (ImGui::Button("front (1)")) view_request_ = ViewPreset::Front;
  ImGui::SameLine();
  if (ImGui::Button("side (2)")) view_request_ = ViewPreset::Side;
  ImGui::SameLine();
  if (ImGui::Button("top (3)")) view_request_ = ViewPreset::Top;
  if (ImGui::RadioButton("fly", !orbit) && orbit) mode_request_ = false;
  ImGui::SameLine();
  if (ImGui::RadioButton("orbit (O)", orbit) && !orbit) mode_request_ = true;
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
    viewpoints_.push_back(SavedViewpoint{"view " + std::to_string(next_viewpoint_++), camera.pose().position,
                                         camera.forward()});
  }
  std::optional<std::size_t> erase;
  for (std::size_t i = 0; i < viewpoints_.size(); ++i) {
    const SavedViewpoint& v = viewpoints_[i];
    ImGui::PushID(static_cast<int>(i));
    if (ImGui::SmallButton("go")) camera.look(v.position, v.forward);
    ImGui::SameLine();
    if (ImGui::SmallButton("x")) erase = i;
    ImGui::SameLine();
    ImGui::Text("%s  (%.1f %.1f %.1f)", v.name.c_str(), v.position.x, v.position.y, v.position.z);
    ImGui::PopID();
  }
  if (erase) viewpoints_.erase(viewpoints_.begin() + static_cast<std::ptrdiff_t>(*erase));
  if (ImGui::CollapsingHeader("help: keys and mouse")) {
    ImGui::TextDisabled("W/S A/D   forward/back, sideways");
    ImGui::TextDisabled("E/Q       along the scene's up/down");
    ImGui::TextDisabled("Shift     x%.0f speed", FlyCamera::kFastFactor);
    ImGui::TextDisabled("right drag  look around");
    ImGui::TextDisabled("wheel     fly: speed; orbit: zoom");
    ImGui::TextDisabled("left drag   orbit: turn about the pivot");
    ImGui::TextDisabled("middle drag orbit: pan");
    ImGui::TextDisabled("F or 1    frame the scene again (front)");
    ImGui::TextDisabled("2 / 3     the side / top view of it");
    ImGui::TextDisabled("O         orbit <-> fly (the view stays)");
    ImGui::TextDisabled("P         screenshot (PNG, path shown below)");
    ImGui::TextDisabled("drop a file  open it (PLY, SPZ, SOG, .splat)");
  }
  ImGui::End();
}

void Panels::draw_framing(FlyCamera& camera) {
  // The box the default camera frames, as the source computed it.
  if (const auto box = source_->bounds()) {
    ImGui::Text("bounds (2-98 %%%s):", box->opacity_weighted ? ", by opacity" : "");
    for (int a = 0; a < 3; ++a)
      ImGui::Text("  %c %9.3f .. %9.3f", "xyz"[a], box->lo[a], box->hi[a]);
    if (box->finite == 0) ImGui::TextColored(ImVec4(1.0f, 0.6f, 0.3f, 1.0f), "  no finite centre: a unit box");
  } else if (const auto view = source_->host_view()) {
    ImGui::Text("host's subject (%s view):", view->flags & msg::kViewInside ? "inside" : "outside");
    for (int a = 0; a < 3; ++a)
      ImGui::Text("  %c %9.3f .. %9.3f", "xyz"[a], view->subject_min[a], view->subject_max[a]);
  } else {
    ImGui::TextDisabled("subject: the host's, once its scene is described");
  }
  // Up: the six axes, and the detected vector when it is none of them (a trainer's cameras).
  static constexpr const char* kAxes[] = {"+x", "-x", "+y", "-y", "+z", "-z"};
  const SceneUp& detected = source_->up();
  const std::string detected_label = "capture " + up_label(detected.up);
  const bool detected_is_axis = up_label(detected.up).size() == 2;
  int current = 6;
  for (int i = 0; i < 6; ++i)
    if (glm::dvec3 a = *parse_up_axis(kAxes[i]); glm::length(a - camera.up()) < 1e-9) current = i;
  const char* shown = current < 6 ? kAxes[current] : detected_label.c_str();
  ImGui::SetNextItemWidth(110.0f);
  if (ImGui::BeginCombo("up", shown)) {
    for (int i = 0; i < 6; ++i)
      if (ImGui::Selectable(kAxes[i], i == current) && i != current) up_request_ = *parse_up_axis(kAxes[i]);
    if (!detected_is_axis && ImGui::Selectable(detected_label.c_str(), current == 6) && current != 6)
      up_request_ = detected.up;
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  if (ImGui::Button("frame (F)")) view_request_ = ViewPreset::Front;
  // Wrapped: the detail may name a file's path.
  ImGui::PushTextWrapPos(0.0f);
  ImGui::TextDisabled("scene's up %s, from %s", up_label(detected.up).c_str(), detected.detail.c_str());
  if (!detected.problem.empty()) ImGui::TextColored(ImVec4(1.0f, 0.6f, 0.3f, 1.0f), "%s", detected.problem.c_str());
  ImGui::PopTextWrapPos();
}

}  // namespace gauss::view
