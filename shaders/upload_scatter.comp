#version 460
// Copies words from the source binding to the destination binding following a piece
// table (shared/upload_scatter_layout.h): StagedUploads' many-region copy groups, applied
// by one dispatch instead of one vkCmdCopyBuffer region per run of slots.
#extension GL_GOOGLE_include_directive : require

#include "upload_scatter_layout.h"

layout(local_size_x = UPLOAD_SCATTER_WORKGROUP) in;
layout(std430, binding = UPLOAD_SCATTER_BINDING_SRC) readonly buffer Src { uint src_words[]; };
layout(std430, binding = UPLOAD_SCATTER_BINDING_DST) writeonly buffer Dst { uint dst_words[]; };
layout(std430, binding = UPLOAD_SCATTER_BINDING_PIECES) readonly buffer Pieces { UploadScatterPiece pieces[]; };
layout(push_constant) uniform Push { UploadScatterPush pc; };

void main() {
  const uint lane = gl_LocalInvocationID.x % UPLOAD_SCATTER_LANES;
  const uint piece = pc.first_piece + gl_WorkGroupID.x * UPLOAD_SCATTER_PIECES_PER_GROUP +
                     gl_LocalInvocationID.x / UPLOAD_SCATTER_LANES;
  if (piece >= pc.piece_end) return;  // the last workgroup's spare lanes; no barriers follow
  const UploadScatterPiece p = pieces[piece];
  for (uint i = lane; i < p.words; i += UPLOAD_SCATTER_LANES) dst_words[p.dst_word + i] = src_words[p.src_word + i];
}
