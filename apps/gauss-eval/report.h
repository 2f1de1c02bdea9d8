#pragma once
// report.md from report.json's content: the tables (fidelity, semantic reallocation, and
// whatever else the run measured), the panels beside them, the definitions, the timing.
#include <filesystem>

#include "gauss/engine/result.h"
#include "measure.h"

namespace gauss::eval_app {

// Writes `path`. `images`: the PNG panels exist next to it. Fails naming the file.
Status write_markdown(const std::filesystem::path& path, const Json& report, bool images);

}  // namespace gauss::eval_app
