// Checkpoints of a progressive render: the film's exact accumulation state plus the render's
// state, in one multi-channel OpenEXR file that any EXR viewer can also open (its R, G, B are
// the current mean image).
//
// Doubles are stored bit-exactly as two UINT channels (low and high 32 bits), counts as UINT,
// AOV running means as FLOAT, so that "render N passes, checkpoint, resume to M passes" equals
// "render M passes straight" bit for bit in deterministic mode. Written atomically.
//
// Only the AOVs the film keeps are stored (channels albedo.RGB, normal.XYZ, depth.Z); the set a
// checkpoint holds is read from its channels, so checkpoints written before AOVs were optional
// (all three always present) read as AovSet::all(). A checkpoint resumes only into a film with
// exactly its AOVs: an AOV missing from it cannot start from zero without wrong means.
#pragma once

#include <cstdint>
#include <string>

#include "sampling/film.h"

namespace tessera {

/// What a checkpoint records besides the film.
struct CheckpointState {
    uint32_t passes = 0;        ///< passes completed (the next pass to render)
    uint32_t seed = 0;          ///< sequence seed (must match on resume)
    /// sampling::pattern_name of the sequence's pattern (must match on resume; a checkpoint
    /// written before patterns existed reads as "padded").
    std::string pattern = "padded";
    double elapsed_s = 0;       ///< render time spent so far
    std::string scene;          ///< scene file the render came from
    std::string settings;       ///< one line of sampler settings (informative, and compared)
};

/// Writes `film` and `state` to `path` atomically. Throws std::runtime_error on failure.
void write_checkpoint(const std::string &path, const sampling::Film &film,
                      const CheckpointState &state);

/// The AOVs stored in the checkpoint at `path` (reads the header only). Throws SceneError
/// ("path:0: message") for a missing or foreign file.
sampling::AovSet checkpoint_aovs(const std::string &path);

/// Reads a checkpoint into `film` (which must have the checkpoint's resolution and AOVs, see
/// checkpoint_aovs) and returns its state. Throws SceneError ("path:0: message") for a missing,
/// foreign or mismatched file.
CheckpointState read_checkpoint(const std::string &path, sampling::Film &film);

}  // namespace tessera
