// Panels: connection, stream and objects (the panels that read the stream; see panels.h).
#include <algorithm>
#include <cstdio>
#include <set>

#include <imgui.h>

#include "panels.h"

namespace gauss::view {
namespace {

const ImVec4 kGood{0.45f, 0.85f, 0.45f, 1.0f};
const ImVec4 kStreamWarn{0.95f, 0.80f, 0.30f, 1.0f};
const ImVec4 kBad{1.0f, 0.35f, 0.30f, 1.0f};
const ImVec4 kDim{0.6f, 0.6f, 0.6f, 1.0f};
constexpr const char* kNoStream = "local scene (no stream)";

// "1.2 MB/s"
std::string rate_text(double bytes_per_s) { return bytes_text(bytes_per_s) + "/s"; }

std::string epoch_text(const std::optional<Epoch>& e) {
  return e ? std::to_string(to_underlying(*e)) : std::string("-");
}

}  // namespace

Panels::Panels(const ViewOptions& opts, ViewSource& source) : source_(&source), rt_(source.runtime()) {
  settings_.stereo = opts.stereo_ipd > 0.0;
  if (opts.stereo_ipd > 0.0) settings_.ipd = opts.stereo_ipd;
  settings_.highlight = opts.highlight;
  settings_.tint_edits = opts.edit_tints;
}

void Panels::place(float x, float y, float w, float h, bool collapsed) const {
  ImGui::SetNextWindowPos(ImVec2(x, y), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(w, h), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowCollapsed(collapsed, ImGuiCond_FirstUseEver);
}

void Panels::draw_connection(double now_s) {
  if (!ImGui::Begin("connection")) {
    ImGui::End();
    return;
  }
  if (rt_ == nullptr) {
    ImGui::TextUnformatted(kNoStream);
    ImGui::TextWrapped("%s", source_->describe().c_str());
    ImGui::End();
    return;
  }
  const client::ConnectionInfo c = rt_->connection();
  const bool welcomed = last_.has_value() && last_->welcomed;  // no lock per frame: a publication step may hold it
  ImGui::Text("host       %s", c.server.c_str());
  ImGui::TextUnformatted("state      ");
  ImGui::SameLine(0.0f, 0.0f);
  switch (c.status) {
    case net::ClientStatus::Connected:
      ImGui::TextColored(kGood, welcomed ? "connected" : "connected, awaiting welcome");
      break;
    case net::ClientStatus::Connecting:
      if (c.counters.disconnects > 0) {
        // The host went away: the last published state keeps rendering meanwhile.
        ImGui::TextColored(kBad, "DISCONNECTED");
        ImGui::PushStyleColor(ImGuiCol_Text, kStreamWarn);
        ImGui::TextWrapped("reconnecting; showing the last published state");
        ImGui::PopStyleColor();
      } else {
        ImGui::TextColored(kStreamWarn, "connecting...");
      }
      if (c.counters.turned_away > 0 && !c.counters.last_rejection.empty()) {
        // The host has no place for now (full, or too many new sessions): it is retried.
        ImGui::PushStyleColor(ImGuiCol_Text, kStreamWarn);
        ImGui::TextWrapped("%s; retrying", c.counters.last_rejection.c_str());
        ImGui::PopStyleColor();
      }
      break;
    case net::ClientStatus::Refused:
      ImGui::TextColored(kBad, "refused");
      if (!c.counters.last_rejection.empty()) ImGui::TextWrapped("%s", c.counters.last_rejection.c_str());
      break;
    case net::ClientStatus::Stopped:
      ImGui::TextColored(kDim, "stopped");
      break;
  }
  if (rates_.at_s < 0.0) {
    rates_ = Rates{now_s, c.counters.bytes_received, c.counters.bytes_sent, 0.0, 0.0, c.counters.thread_cpu_ms, 0.0};
  } else if (now_s - rates_.at_s >= kRateWindowS) {
    const double dt = now_s - rates_.at_s;
    rates_.in_per_s = static_cast<double>(c.counters.bytes_received - rates_.in) / dt;
    rates_.out_per_s = static_cast<double>(c.counters.bytes_sent - rates_.out) / dt;
    rates_.net_cpu_share = (c.counters.thread_cpu_ms - rates_.net_cpu_ms) * 1e-3 / dt;
    rates_.in = c.counters.bytes_received;
    rates_.out = c.counters.bytes_sent;
    rates_.net_cpu_ms = c.counters.thread_cpu_ms;
    rates_.at_s = now_s;
  }
  ImGui::Text("in         %s", rate_text(rates_.in_per_s).c_str());
  ImGui::Text("out        %s", rate_text(rates_.out_per_s).c_str());
  if (c.counters.thread_cpu_ms >= 0.0) ImGui::Text("net thread %.0f %% of a core", 100.0 * rates_.net_cpu_share);
  ImGui::Text("reconnects %llu", static_cast<unsigned long long>(c.counters.connects > 0 ? c.counters.connects - 1 : 0));
  ImGui::End();
}

void Panels::draw_stream() {
  if (!ImGui::Begin("stream")) {
    ImGui::End();
    return;
  }
  if (rt_ == nullptr) {
    ImGui::TextUnformatted(kNoStream);
    ImGui::Text("resident   %u", source_->renderer().occupied_count());
    ImGui::End();
    return;
  }
  const client::DisplayFrameStats s = last_.value_or(client::DisplayFrameStats{});
  const ClientStatsCounters& counters = s.counters;
  ImGui::Text("budget M   %u", rt_->capacity());
  ImGui::Text("resident   %u", s.resident);
  ImGui::Text("desired    %llu", static_cast<unsigned long long>(s.desired));
  ImGui::Text("pending    %u", s.pending);
  ImGui::Text("epoch      gaussians %s  surface %s", epoch_text(s.published_epoch).c_str(),
              epoch_text(s.surface_epoch).c_str());
  ImGui::Text("edits      %u this frame", s.publish.edits());
  // Slot writes a frame may make: adaptive in progressive mode, fixed in immediate mode.
  ImGui::Text("allowance  %u (%s)", s.publish.allowance,
              rt_->publish_mode() == PublishMode::Immediate ? "fixed" : "follows the display");
  ImGui::Text("publisher  %s", s.publication_threaded ? "own thread" : "display thread");
  ImGui::Text("batches    %llu  resyncs %llu", static_cast<unsigned long long>(counters.batches),
              static_cast<unsigned long long>(counters.resyncs));
  int mode = rt_->publish_mode() == PublishMode::Immediate ? 0 : 1;
  ImGui::TextUnformatted("publish");
  ImGui::SameLine();
  bool changed = ImGui::RadioButton("immediate", &mode, 0);
  ImGui::SameLine();
  changed |= ImGui::RadioButton("progressive", &mode, 1);
  if (changed) rt_->set_publish_mode(mode == 0 ? PublishMode::Immediate : PublishMode::Progressive);
  ImGui::End();
}

void Panels::refresh_objects(double now_s) {
  if (rt_ == nullptr || (objects_at_s_ >= 0.0 && now_s - objects_at_s_ < kSlowRefreshS)) return;
  struct Snap {
    std::map<std::int32_t, std::uint32_t> per_object;
    std::vector<ObjectRow> rows;
    std::vector<ObjectId> targets;
  };
  // Skipped (tried again next frame) while a publication step holds the state.
  auto taken = rt_->try_with_state([](const ClientState& st) {
    Snap out;
    out.per_object = client::ClientRuntime::resident_per_object(st);
    out.targets = st.query_targets();
    for (const auto& [id, info] : st.objects()) out.rows.push_back(ObjectRow{id, info.label, info.member_count, 0});
    return out;
  });
  if (!taken) return;
  objects_at_s_ = now_s;
  Snap& snap = *taken;
  const std::map<std::int32_t, std::uint32_t>& per_object = snap.per_object;
  std::set<std::string> labels;
  for (ObjectRow& row : snap.rows) {
    if (auto it = per_object.find(row.id); it != per_object.end()) row.resident = it->second;
    labels.insert(row.label);
  }
  objects_ = std::move(snap.rows);
  targets_ = std::move(snap.targets);
  target_resident_ = 0;
  for (ObjectId t : targets_)
    if (auto it = per_object.find(to_underlying(t)); it != per_object.end()) target_resident_ += it->second;
  classes_.assign(labels.begin(), labels.end());
  class_index_ = std::clamp(class_index_, 0, std::max(0, static_cast<int>(classes_.size()) - 1));
}

void Panels::draw_objects(double now_s) {
  if (!ImGui::Begin("objects")) {
    ImGui::End();
    return;
  }
  if (rt_ == nullptr) {
    ImGui::TextUnformatted(kNoStream);
    ImGui::End();
    return;
  }
  refresh_objects(now_s);
  ImGui::SetNextItemWidth(120.0f);
  ImGui::SliderFloat("rho", &rho_, 0.0f, 1.0f, "%.2f");
  ImGui::SameLine();
  if (ImGui::Button("clear")) {
    rt_->clear_query();
    last_query_ = "cleared";
  }
  ImGui::SetNextItemWidth(120.0f);
  const char* preview = classes_.empty() ? "(no objects)" : classes_[static_cast<std::size_t>(class_index_)].c_str();
  if (ImGui::BeginCombo("##class", preview)) {
    for (int i = 0; i < static_cast<int>(classes_.size()); ++i) {
      if (ImGui::Selectable(classes_[static_cast<std::size_t>(i)].c_str(), i == class_index_)) class_index_ = i;
    }
    ImGui::EndCombo();
  }
  ImGui::SameLine();
  if (ImGui::Button("query class") && !classes_.empty()) {
    msg::Query q;
    q.kind = msg::QueryKind::ClassText;
    q.text = classes_[static_cast<std::size_t>(class_index_)];
    q.rho = rho_;
    rt_->send_query(q);
    last_query_ = "class \"" + q.text + "\"";
  }
  const std::uint32_t m = rt_->capacity();
  if (targets_.empty()) {
    ImGui::TextColored(kDim, "no active query%s%s", last_query_.empty() ? "" : "; last: ", last_query_.c_str());
  } else {
    ImGui::Text("query %s: %zu objects", last_query_.c_str(), targets_.size());
    ImGui::Text("share of M %.1f %% (%llu resident)", m > 0 ? 100.0 * static_cast<double>(target_resident_) / m : 0.0,
                static_cast<unsigned long long>(target_resident_));
  }
  const ImGuiTableFlags flags = ImGuiTableFlags_RowBg | ImGuiTableFlags_ScrollY | ImGuiTableFlags_BordersInnerV |
                                ImGuiTableFlags_SizingFixedFit;
  if (ImGui::BeginTable("objects", 5, flags, ImVec2(0.0f, ImGui::GetContentRegionAvail().y))) {
    ImGui::TableSetupScrollFreeze(0, 1);
    ImGui::TableSetupColumn("id");
    ImGui::TableSetupColumn("class", ImGuiTableColumnFlags_WidthStretch);
    ImGui::TableSetupColumn("members");
    ImGui::TableSetupColumn("resident");
    ImGui::TableSetupColumn("");
    ImGui::TableHeadersRow();
    for (const ObjectRow& row : objects_) {
      const bool target = std::find(targets_.begin(), targets_.end(), ObjectId{row.id}) != targets_.end();
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::Text("%d", row.id);
      ImGui::TableNextColumn();
      if (target) {
        ImGui::TextColored(kGood, "%s", row.label.c_str());
      } else {
        ImGui::TextUnformatted(row.label.c_str());
      }
      ImGui::TableNextColumn();
      ImGui::Text("%u", row.members);
      ImGui::TableNextColumn();
      ImGui::Text("%u", row.resident);
      ImGui::TableNextColumn();
      ImGui::PushID(row.id);
      if (ImGui::SmallButton("query")) {
        msg::Query q;
        q.kind = msg::QueryKind::Instance;
        q.instance = ObjectId{row.id};
        q.rho = rho_;
        rt_->send_query(q);
        last_query_ = "instance " + std::to_string(row.id);
      }
      ImGui::PopID();
    }
    ImGui::EndTable();
  }
  ImGui::End();
}

}  // namespace gauss::view
