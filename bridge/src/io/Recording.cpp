// Writing and reading recorded interface messages.
#include "io/Recording.hpp"
#include "railcosim/Error.hpp"

#include <chrono>
#include <cstring>
#include <sstream>

namespace railcosim::io {
namespace {

const char* const magicLine = "railcosim-recording 1";
// Same bound as the protocol's largest message, so a corrupt size cannot allocate unbounded memory.
constexpr std::uint64_t maxRecordBytes = 16ull << 30;

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

} // namespace

RecordingWriter::RecordingWriter(const std::string& path, const std::string& role)
    : path_(path), out_(path, std::ios::binary | std::ios::trunc), start_(now()) {
  if (!out_) throw Error("recording: cannot create '" + path + "' (" + std::strerror(errno) + ")");
  out_ << magicLine << '\n' << role << '\n';
  out_.flush();
}

void RecordingWriter::write(bool sent, const std::uint8_t* data, std::size_t size) {
  const std::uint8_t direction = sent ? 1 : 0;
  const double seconds = now() - start_;
  const std::uint64_t bytes = size;
  out_.write(reinterpret_cast<const char*>(&direction), 1);
  out_.write(reinterpret_cast<const char*>(&seconds), sizeof seconds);
  out_.write(reinterpret_cast<const char*>(&bytes), sizeof bytes);
  out_.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out_.flush();
  if (!out_) throw Error("recording: writing to '" + path_ + "' failed (disk full?)");
}

Recording readRecording(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("recording '" + path + "': cannot open it (" + std::strerror(errno) + ")");
  Recording recording;
  std::string magic;
  std::getline(in, magic);
  if (magic != magicLine) {
    throw Error("recording '" + path + "': not a railcosim recording (first line '" + magic.substr(0, 40) +
                "', expected '" + magicLine + "')");
  }
  std::getline(in, recording.role);
  if (recording.role != "fem" && recording.role != "dem") {
    throw Error("recording '" + path + "': recorder role '" + recording.role + "', expected fem or dem");
  }
  while (true) {
    const std::streamoff offset = in.tellg();
    std::uint8_t direction = 0;
    RecordedMessage message;
    std::uint64_t size = 0;
    if (!in.read(reinterpret_cast<char*>(&direction), 1)) break; // clean end
    if (!in.read(reinterpret_cast<char*>(&message.seconds), sizeof message.seconds) ||
        !in.read(reinterpret_cast<char*>(&size), sizeof size)) {
      break; // cut short at the end
    }
    if (direction > 1 || size > maxRecordBytes) {
      std::ostringstream text;
      text << "recording '" << path << "': record at byte " << offset << " is corrupt (direction " << int(direction)
           << ", size " << size << ")";
      throw Error(text.str());
    }
    message.sent = direction == 1;
    message.bytes.resize(size);
    if (!in.read(reinterpret_cast<char*>(message.bytes.data()), static_cast<std::streamsize>(size))) break;
    recording.messages.push_back(std::move(message));
  }
  return recording;
}

} // namespace railcosim::io
