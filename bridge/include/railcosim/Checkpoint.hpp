// Restart checkpoints on disk: one folder per checkpoint, both participants' files, a manifest written last.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace railcosim {

/// Where a participant writes checkpoints and which one it resumes from. `fromEnvironment()` reads what
/// `./railcosim run --checkpoint-every / --resume` sets for both solvers:
///   RAILCOSIM_CHECKPOINT_DIR   the folder holding the checkpoints (the same for both sides)
///   RAILCOSIM_RESUME           the checkpoint folder to start from ("" or unset: a fresh run)
///   RAILCOSIM_CHECKPOINT_RUN   what identifies the run (case and parameters), stored in each manifest
struct CheckpointSettings {
  std::string folder;
  std::string resumeFrom;
  std::string run;
  static CheckpointSettings fromEnvironment();
};

/// One file of a checkpoint: which side wrote it, its name in the checkpoint folder, where it goes back when a run
/// resumes (a path relative to that side's working folder; "" for state that the solver reads itself), its size
/// and CRC-32 (ISO 3309, as zlib's crc32).
struct CheckpointFile {
  std::string side; // "dem" | "fem"
  std::string name;
  std::string restoreTo;
  std::uint64_t bytes = 0;
  std::uint32_t crc32 = 0;
};

/// manifest.json of a checkpoint folder (docs/protocol.md §12).
struct CheckpointManifest {
  std::string name;                  // the folder's name, e.g. "window-00000800"
  std::uint16_t protocolVersion = 0; // bridge protocol of both participants
  std::uint64_t window = 0;          // windows completed: the run continues with window `window`
  double time = 0.0;                 // s since the handshake, t_window
  std::string scheme;                // the coupling scheme agreed at the handshake
  std::string run;                   // CheckpointSettings::run of the saving run
  std::vector<CheckpointFile> files;
};

/// The folder name of the checkpoint taken after `window` windows: "window-00000800".
std::string checkpointName(std::uint64_t window);
/// ROOT/NAME.partial, where both sides write before the manifest commits the checkpoint.
std::string stagingFolder(const std::string& root, const std::string& name);

/// Size and CRC-32 of `folder`/`name`; throws Error naming the file if it cannot be read.
CheckpointFile describeCheckpointFile(const std::string& folder, const std::string& name, const std::string& side,
                                      const std::string& restoreTo = "");
/// Copies `source` into the staging folder as `name` and describes it (restored to `restoreTo` on resume).
CheckpointFile copyIntoCheckpoint(const std::string& staging, const std::string& source, const std::string& name,
                                  const std::string& side, const std::string& restoreTo);

/// A side's files as one text (one line each), as the FEM side reports them to the DEM side, and back.
std::string encodeCheckpointFiles(const std::vector<CheckpointFile>& files);
std::vector<CheckpointFile> decodeCheckpointFiles(const std::string& text);

/// Empties and creates ROOT/NAME.partial (what a save interrupted before left there is discarded); returns its path.
std::string prepareCheckpoint(const std::string& root, const std::string& name);
/// Commits a staged checkpoint: writes manifest.json (flushed to disk; its protocol version is this build's, whatever
/// `manifest.protocolVersion` says) into the staging folder, renames the folder
/// to ROOT/NAME and keeps only the `keep` newest complete checkpoints (older ones and stale staging folders go).
/// A checkpoint is complete exactly when its folder has that name: a save interrupted at any point leaves a
/// .partial folder, which is never resumed from.
void commitCheckpoint(const std::string& root, const CheckpointManifest& manifest, int keep = 2);

/// The manifest of a checkpoint folder, checked: complete (manifest.json present and readable), written by this
/// protocol version, every file present with its size and CRC-32. Throws CheckpointError (one line: the folder and
/// what is wrong).
CheckpointManifest verifyCheckpoint(const std::string& folder);
/// The newest complete checkpoint folder under `root` ("" when there is none).
std::string latestCheckpoint(const std::string& root);
/// Copies `side`'s files that have a restoreTo back under `workFolder` (each through a temporary file and a rename).
void restoreCheckpointFiles(const std::string& folder, const CheckpointManifest& manifest, const std::string& side,
                            const std::string& workFolder);
/// An output file's path relative to the working folder (the run's results folder), where it goes back on resume
/// (copyIntoCheckpoint's restoreTo). Throws std::invalid_argument, naming `caller`, for a path outside that folder.
std::string relativeToWorkFolder(const std::string& path, const std::string& caller);

/// Refuses a checkpoint that does not fit the resuming run: CheckpointError "checkpoint FOLDER: WHAT; resume with the
/// case and parameters of the interrupted run".
[[noreturn]] void refuseResume(const std::string& folder, const std::string& what);
/// The coupling a DEM side's state was saved under, read back from its state file.
struct SavedCoupling {
  double femDt = 0.0;             // the FEM side's window length [s]
  std::int64_t subcycles = 0;     // DEM steps per window
  std::vector<double> triangles;  // the interface's triangles, 3 node indices each
  std::int64_t window = 0;        // windows completed
};
/// Refuses (refuseResume) a saved coupling whose window length, steps per window or triangles differ from this run's,
/// or whose window is not the manifest's.
void checkSavedCoupling(const std::string& folder, const SavedCoupling& saved, double femDt, std::int64_t subcycles,
                        const std::vector<double>& triangles, std::uint64_t manifestWindow);

/// What the DEM side adds to a checkpoint the FEM side has staged its files in.
struct DemCheckpointContent {
  std::string stateFile;                                     // written into the staging folder, side "dem"
  std::vector<std::pair<std::string, std::string>> sections; // (section name, bytes) of the state file, in order
  std::vector<std::string> files;                            // output files copied in, restored where they were
  std::string caller;                                        // named in errors (relativeToWorkFolder)
};
/// Completes a staged checkpoint on the DEM side: writes the state file (StateWriter sections, then "end"), copies
/// the files, and commits the manifest with the FEM side's `femFiles` (commitCheckpoint). Returns ROOT/NAME.
std::string completeDemCheckpoint(const std::string& root, CheckpointManifest manifest, const DemCheckpointContent& content,
                                  const std::vector<CheckpointFile>& femFiles);

} // namespace railcosim
