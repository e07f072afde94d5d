// railcosim_checkpoint: checks restart checkpoints for the case runner (one implementation of the manifest rules).
#include "DummyCommon.hpp"

#include "railcosim/Checkpoint.hpp"
#include "railcosim/Error.hpp"

#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>

using namespace railcosim;

namespace {

const char* usage =
    "railcosim_checkpoint: restart checkpoints of a coupled run (docs/protocol.md section 12).\n"
    "  railcosim_checkpoint latest ROOT     the newest complete checkpoint folder under ROOT (exit 1: none)\n"
    "  railcosim_checkpoint verify FOLDER   checks FOLDER (manifest, protocol version, every file's size and CRC-32)\n"
    "                                       and prints its manifest as one JSON line; a refusal is one line on\n"
    "                                       stderr and exit status 2\n";

std::string json(const std::string& text) {
  std::ostringstream out;
  out << '"';
  for (unsigned char c : text) {
    if (c == '"' || c == '\\')
      out << '\\' << c;
    else if (c < 0x20)
      out << "\\u" << std::hex << std::setw(4) << std::setfill('0') << static_cast<int>(c) << std::dec;
    else
      out << c;
  }
  return out.str() + '"';
}

} // namespace

int main(int argc, char** argv) {
  const std::string command = argc == 3 ? argv[1] : "";
  if (command == "latest") {
    const std::string folder = latestCheckpoint(argv[2]);
    if (folder.empty()) return 1;
    std::printf("%s\n", folder.c_str());
    return 0;
  }
  if (command == "verify") {
    try {
      const CheckpointManifest manifest = verifyCheckpoint(argv[2]);
      std::ostringstream out;
      out << std::setprecision(17) << "{\"name\": " << json(manifest.name)
          << ", \"protocol_version\": " << manifest.protocolVersion << ", \"window\": " << manifest.window
          << ", \"time\": " << manifest.time << ", \"scheme\": " << json(manifest.scheme)
          << ", \"run\": " << json(manifest.run) << ", \"files\": " << manifest.files.size() << "}";
      std::printf("%s\n", out.str().c_str());
      return 0;
    } catch (const Error& error) {
      std::fprintf(stderr, "%s\n", error.what());
      return 2;
    }
  }
  std::fprintf(stderr, "%s", usage);
  return command == "--help" ? 0 : 2;
}
