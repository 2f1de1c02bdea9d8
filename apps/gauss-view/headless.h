#pragma once
// gauss-view --headless: flies a camera path (client/camera_path.h) through a ViewSource
// and writes what it saw. A local scene without --path holds its default camera
// (default_view.h: its robust bounds framed from outside, upright for its up) for a few
// frames, as a path of one still pose; summary.json's "default_camera" then gives the
// bounds, the up and where the up came from, the eye and the target.
//   OUT/frames/frame_NNNNNN.png     every --every'th path frame (+ _right for stereo)
//   OUT/frames.jsonl                one line per frame: CPU ms (publication, upload,
//                                   render), GPU ms per pass, resident / desired / pending,
//                                   published Gaussian and surface epochs, edits published,
//                                   whether the host connection was up (welcomed)
//   OUT/final.png, final_camera.json  the last frame, after the stream settled
//   OUT/final_slot_ids.json         the published Gaussian ids in slot order (stream only)
//   OUT/summary.json                counts, the query's share of M, per-object residency,
//                                   frame-time percentiles, connection counters
//   OUT/events.jsonl                the client's stage events (stream only)
//   OUT/contact_sheet.png, report.md  the frames tiled, and the summary for a person
// The path's clock is the frame counter (frame k is at t = k / fps), so a path gives the
// same cameras on every machine; the stream arrives in real time. After the last
// keyframe the final camera holds until the source is settled or the settle time ends.
// Exit status: 0 settled, 3 not settled in time (everything is still written), 1 error
// (a bad path file, a refused connection: the message names it).
#include "options.h"
#include "view_source.h"

namespace gauss::view {

int run_headless(const ViewOptions& opts, vk::Context& context);

}  // namespace gauss::view
