// Layout of shaders/upload_scatter.comp: StagedUploads applies a copy group of many small
// regions as one dispatch of this shader instead of one vkCmdCopyBuffer region per run
// (render/src/vk/upload_scatter.h says why and when).
//
// A piece table lists what to copy: piece i moves pieces[i].words words (1 ..
// UPLOAD_SCATTER_PIECE_WORDS) from word src_word of the source binding to word dst_word
// of the destination binding (word offsets from each binding's start). A region longer
// than a piece is split into several. Pieces of one dispatch never write the same word.
//
// Shape: UPLOAD_SCATTER_LANES consecutive invocations copy one piece, lane k taking words
// k, k + LANES, ...: consecutive invocations touch consecutive words, so a GPU loads and
// stores a piece's words in whole memory transactions. A workgroup takes
// UPLOAD_SCATTER_PIECES_PER_GROUP consecutive pieces. No subgroup operations: the result
// does not depend on the subgroup size.
#ifndef GAUSS_SHADERS_SHARED_UPLOAD_SCATTER_LAYOUT_H
#define GAUSS_SHADERS_SHARED_UPLOAD_SCATTER_LAYOUT_H

#include "glsl_cpp.h"

GAUSS_SHARED_BEGIN

GAUSS_CONST(uint, UPLOAD_SCATTER_WORKGROUP, 256u)
// Invocations per piece: a 32-wide GPU subgroup covers one piece's 128 consecutive bytes
// per step; a slot's 64-byte core record (16 words) is one step.
GAUSS_CONST(uint, UPLOAD_SCATTER_LANES, 32u)
GAUSS_CONST(uint, UPLOAD_SCATTER_PIECES_PER_GROUP, 8u)  // WORKGROUP / LANES
// Longest piece: 4 KiB, 32 steps of the piece's lanes. Longer regions are split so a long
// region spreads over workgroups instead of keeping 32 invocations busy alone.
GAUSS_CONST(uint, UPLOAD_SCATTER_PIECE_WORDS, 1024u)

GAUSS_BINDING(UPLOAD_SCATTER_BINDING_SRC, 0u)     // uint words, read
GAUSS_BINDING(UPLOAD_SCATTER_BINDING_DST, 1u)     // uint words, written
GAUSS_BINDING(UPLOAD_SCATTER_BINDING_PIECES, 2u)  // UploadScatterPiece[], read

struct UploadScatterPiece {
  uint src_word;
  uint dst_word;
  uint words;
};

struct UploadScatterPush {
  uint first_piece;  // pieces [first_piece, piece_end) of the table, this dispatch's
  uint piece_end;
};

GAUSS_SHARED_END

GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::UploadScatterPiece) == 12, "std430 stride of UploadScatterPiece is 12");
GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::UploadScatterPush) == 8, "UploadScatterPush must be 8 bytes");
GAUSS_STATIC_ASSERT(gauss::gpu::UPLOAD_SCATTER_PIECES_PER_GROUP * gauss::gpu::UPLOAD_SCATTER_LANES ==
                        gauss::gpu::UPLOAD_SCATTER_WORKGROUP,
                    "a workgroup is a whole number of pieces");

#endif  // GAUSS_SHADERS_SHARED_UPLOAD_SCATTER_LAYOUT_H
