// A run's interface messages in one file, as they crossed the wire: written by a participant, read by the replay.
#pragma once

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace railcosim::io {

/// File layout (little-endian, as written on x86-64 and aarch64): the line "railcosim-recording 1", the line
/// naming the recording participant's role ("fem" or "dem"), then one record per message:
/// u8 direction (1 sent by the recorder, 0 received), f64 seconds since the recorder opened, u64 size, bytes.
/// Keepalive frames are transport, not messages, and are not recorded.
struct RecordedMessage {
  bool sent = false;
  double seconds = 0.0;
  std::vector<std::uint8_t> bytes;
};

struct Recording {
  std::string role; // "fem" | "dem": the side that recorded
  std::vector<RecordedMessage> messages;
};

class RecordingWriter {
public:
  /// Creates (truncates) `path`; throws Error naming it if that fails.
  RecordingWriter(const std::string& path, const std::string& role);
  /// Appends one message and flushes it, so a run that dies keeps what it exchanged.
  void write(bool sent, const std::uint8_t* data, std::size_t size);
  const std::string& path() const { return path_; }

private:
  std::string path_;
  std::ofstream out_;
  double start_;
};

/// Reads a recording; throws Error naming the file and the byte offset of anything malformed. A record
/// cut short at the end (the recorder was killed mid-write) is dropped with the rest intact.
Recording readRecording(const std::string& path);

} // namespace railcosim::io
