// Panels: the scene panel, and the notices over the scene (a load's progress, a failed
// load's error, a screenshot's path; see panels.h).
#include <algorithm>
#include <cstdio>

#include <imgui.h>

#include "panels.h"

namespace gauss::view {
namespace {

const ImVec4 kError{1.0f, 0.45f, 0.40f, 1.0f};
const ImVec4 kSceneWarn{1.0f, 0.6f, 0.3f, 1.0f};

void box_rows(const glm::dvec3& lo, const glm::dvec3& hi) {
  for (int a = 0; a < 3; ++a) ImGui::Text("  %c %9.3f .. %9.3f", "xyz"[a], lo[a], hi[a]);
}

}  // namespace

std::string bytes_text(double bytes) {
  char buf[32];
  if (bytes >= 1e9) {
    std::snprintf(buf, sizeof buf, "%.2f GB", bytes * 1e-9);
  } else if (bytes >= 1e6) {
    std::snprintf(buf, sizeof buf, "%.2f MB", bytes * 1e-6);
  } else if (bytes >= 1e3) {
    std::snprintf(buf, sizeof buf, "%.1f kB", bytes * 1e-3);
  } else {
    std::snprintf(buf, sizeof buf, "%.0f B", bytes);
  }
  return buf;
}

void Panels::set_source(ViewSource& source) {
  source_ = &source;
  rt_ = source.runtime();
  // What was read from the old source means nothing for the new one.
  last_.reset();
  rates_ = Rates{};
  objects_at_s_ = -1.0;
  objects_.clear();
  classes_.clear();
  targets_.clear();
  target_resident_ = 0;
  last_query_.clear();
}

void Panels::show_notice(std::string message, double now_s) {
  notice_ = std::move(message);
  notice_until_s_ = now_s + kNoticeS;
}

void Panels::draw_scene() {
  if (!ImGui::Begin("scene")) {
    ImGui::End();
    return;
  }
  const SceneSummary* s = source_->summary();
  if (s == nullptr) {
    ImGui::TextWrapped("a stream: its Gaussians, budget and epochs are in the stream panel");
    ImGui::TextDisabled("drop a scene file on the window to open it");
    ImGui::End();
    return;
  }
  ImGui::PushTextWrapPos(0.0f);
  ImGui::Text("%s", s->path.filename().string().c_str());
  ImGui::PopTextWrapPos();
  ImGui::Text("format     %s, %s", std::string(to_string(s->format)).c_str(),
              s->file_bytes > 0 ? bytes_text(static_cast<double>(s->file_bytes)).c_str() : "a folder");
  ImGui::Text("Gaussians  %zu, SH degree %d", s->gaussians, s->sh_degree);
  if (s->skipped > 0) ImGui::TextColored(kSceneWarn, "  %llu non-finite, not drawn", static_cast<unsigned long long>(s->skipped));
  ImGui::Text("framed box (2-98 %%%s):", s->robust.opacity_weighted ? ", by opacity" : "");
  box_rows(s->robust.lo, s->robust.hi);
  if (s->full.finite == 0) {
    ImGui::TextColored(kSceneWarn, "full box: no finite centre");
  } else {
    ImGui::Text("full box (%zu finite centres):", s->full.finite);
    box_rows(s->full.lo, s->full.hi);
  }
  ImGui::Text("GPU        %s resident", bytes_text(static_cast<double>(s->resident_bytes)).c_str());
  ImGui::Text("           %s in all its buffers", bytes_text(static_cast<double>(s->renderer_bytes)).c_str());
  ImGui::Text("loaded in  %.2f s + %.2f s upload", s->load_s, s->upload_s);
  ImGui::End();
}

void Panels::draw_notices(std::uint32_t width, std::uint32_t height, double now_s) {
  const bool notice = !notice_.empty() && now_s < notice_until_s_;
  if (loading_ == nullptr && error_.empty() && !notice) return;
  const float w = std::min(560.0f, std::max(200.0f, static_cast<float>(width) - 40.0f));
  ImGui::SetNextWindowPos(ImVec2(0.5f * static_cast<float>(width), static_cast<float>(height) - 8.0f), ImGuiCond_Always,
                          ImVec2(0.5f, 1.0f));
  ImGui::SetNextWindowSize(ImVec2(w, 0.0f), ImGuiCond_Always);
  // Height 0: fitted to the lines each frame.
  const ImGuiWindowFlags flags = ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing |
                                 ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoMove;
  if (!ImGui::Begin("##notices", nullptr, flags)) {
    ImGui::End();
    return;
  }
  ImGui::PushTextWrapPos(0.0f);
  if (loading_ != nullptr) {
    const SceneLoadProgress& p = loading_->progress();
    ImGui::Text("opening %s", loading_->path().filename().string().c_str());
    char label[96];
    const double total = static_cast<double>(p.bytes_total());
    const double elapsed = now_s - loading_since_s_;
    // The readers report nothing while they decode (scene_load.h): after the bytes, the
    // bar stays full and the label says which stage runs.
    switch (p.phase()) {
      case SceneLoadPhase::Reading:
        std::snprintf(label, sizeof label, "reading %.0f %% of %s", 100.0 * p.read_fraction(), bytes_text(total).c_str());
        break;
      case SceneLoadPhase::Decoding:
        std::snprintf(label, sizeof label, "decoding %s ... %.1f s", total > 0 ? bytes_text(total).c_str() : "the folder",
                      elapsed);
        break;
      default:
        std::snprintf(label, sizeof label, "bounds ... %.1f s", elapsed);
        break;
    }
    ImGui::ProgressBar(p.phase() == SceneLoadPhase::Reading ? static_cast<float>(p.read_fraction()) : 1.0f,
                       ImVec2(-1.0f, 0.0f), label);
  }
  if (!error_.empty()) {
    ImGui::TextColored(kError, "could not open:");
    ImGui::TextColored(kError, "%s", error_.c_str());
    ImGui::TextDisabled("the scene shown is unchanged");
    if (ImGui::SmallButton("dismiss")) error_.clear();
  }
  if (notice) ImGui::TextUnformatted(notice_.c_str());
  ImGui::PopTextWrapPos();
  ImGui::End();
}

}  // namespace gauss::view
