// libFuzzer target: hostile bytes through the header decoder and the body decoder it names (docs/protocol.md §10).
//
// Expected outcome for a bad frame: railcosim::ProtocolError, the one type Participant.cpp catches to send the
// peer an Abort. Findings (the process aborts and libFuzzer keeps the input): a crash or sanitizer report, a hang,
// an allocation beyond -malloc_limit_mb, any other exception (a plain railcosim::Error included), and an accepted
// frame that breaks one of the invariants checked below.
#include "protocol/Message.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/CouplingScheme.hpp"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <initializer_list>
#include <string>
#include <vector>

using namespace railcosim;
using namespace railcosim::protocol;

namespace {

/// A header field by byte offset and size (docs/protocol.md §2).
struct Field {
  std::size_t offset, bytes;
};
constexpr Field windowField{8, 8}, flagsField{20, 4}, timeField{24, 8};

[[noreturn]] void finding(const Header& header, const std::string& what) {
  std::fprintf(stderr, "protocol fuzzer finding (%s, %llu bytes payload): %s\n", describe(header).c_str(),
               static_cast<unsigned long long>(header.payloadBytes), what.c_str());
  std::abort();
}

/// The encoder of an accepted frame's content must give back the frame itself: the decoders accept only the
/// canonical layout. `freeFields`: header fields the format leaves to the sender for this type (the encoder
/// writes 0 there); they are copied over before the comparison.
void requireCanonical(const Header& header, const std::uint8_t* data, std::vector<std::uint8_t> encoded,
                      std::initializer_list<Field> freeFields) {
  const std::size_t size = headerBytes + static_cast<std::size_t>(header.payloadBytes);
  if (encoded.size() != size) {
    finding(header, "re-encoded frame has " + std::to_string(encoded.size()) + " bytes, the accepted one " +
                        std::to_string(size));
  }
  for (const Field& field : freeFields) std::memcpy(encoded.data() + field.offset, data + field.offset, field.bytes);
  for (std::size_t i = 0; i < size; ++i) {
    if (encoded[i] != data[i]) {
      finding(header, "accepted frame differs from its re-encoding at byte " + std::to_string(i) +
                          (i < headerBytes ? " (header)" : " (payload)") +
                          ": the decoder let a non-canonical field through");
    }
  }
}

/// The encoding of what a decoder accepted: an encoder refusing it (ProtocolError) means the decoder let through a
/// value no sender can write, which is a finding, not the expected refusal of a bad frame.
template <class Encode>
std::vector<std::uint8_t> reencoded(const Header& header, Encode encode) {
  try {
    return encode();
  } catch (const ProtocolError& error) {
    finding(header, std::string("the encoder refuses what the decoder accepted: ") + error.what());
  }
}

/// The frame copied to an odd address inside `storage`: the array decoders take a fast path for 8-byte aligned
/// payloads and a copying one otherwise, and both must give the same values.
const std::uint8_t* misalignedCopy(const std::uint8_t* data, std::size_t size, std::vector<std::uint8_t>& storage) {
  storage.assign(size + 1, 0);
  std::memcpy(storage.data() + 1, data, size);
  return storage.data() + 1;
}

bool sameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

void fuzzHello(const Header& header, const std::uint8_t* data) {
  const Hello hello = decodeHello(header, data);
  // What the handshake does next with an accepted Hello (Participant.cpp, Link::checkHello and
  // DemParticipant::initialize): the DEM side hands the scheme on as InterfaceSetup::couplingScheme, where
  // parseCouplingScheme reads it. Every scheme the decoder admits must parse, in its canonical spelling.
  if (!hello.couplingScheme.empty()) {
    try {
      if (toString(parseCouplingScheme(hello.couplingScheme)) != hello.couplingScheme) {
        finding(header, "Hello scheme '" + hello.couplingScheme + "' accepted in a non-canonical spelling");
      }
    } catch (const Error& error) {
      finding(header,
              std::string("Hello scheme accepted by decodeHello, refused by parseCouplingScheme: ") + error.what());
    }
  }
  if (hello.participantName.empty()) finding(header, "Hello with an empty participantName accepted");
  if (hello.resumedWindow != header.window) finding(header, "Hello's resumed window is not its header's window");
  if (hello.resumedFrom.empty() && hello.resumedWindow != 0) finding(header, "a resumed window without its checkpoint");
  (void)toString(hello.role);
  requireCanonical(header, data, reencoded(header, [&] { return encodeHello(hello); }), {timeField});
}

void fuzzCheckpoint(const Header& header, const std::uint8_t* data) {
  const CheckpointOrder order = decodeCheckpoint(header, data);
  if (order.name.empty() || order.name.find('/') != std::string::npos)
    finding(header, "Checkpoint accepted a name that is no folder name: '" + order.name + "'");
  requireCanonical(header, data, reencoded(header, [&] { return encodeCheckpoint(order); }), {});
}

void fuzzCheckpointWritten(const Header& header, const std::uint8_t* data) {
  const std::string files = decodeCheckpointWritten(header, data);
  requireCanonical(header, data, reencoded(header, [&] { return encodeCheckpointWritten(header.window, files); }),
                   {timeField});
}

void fuzzMesh(const Header& header, const std::uint8_t* data) {
  const MeshSetup setup = decodeMesh(header, data);
  if (setup.mesh.nodeCount() != header.nodeCount || setup.mesh.triangleCount() != header.triangleCount) {
    finding(header, "InterfaceMesh decoded with other counts than its header");
  }
  try {
    setup.mesh.validate();
    setup.initial.validate(setup.mesh.nodeCount());
  } catch (const Error& error) {
    finding(header, std::string("accepted InterfaceMesh fails validation: ") + error.what());
  }
  requireCanonical(header, data, encodeMesh(setup.mesh, setup.femTimeStep, setup.initial), {windowField});
}

void fuzzForces(const Header& header, const std::uint8_t* data, std::size_t size) {
  const std::size_t agreed = static_cast<std::size_t>(header.nodeCount);
  const ForceMessage forces = decodeForces(header, data, agreed);
  std::vector<std::uint8_t> storage;
  const ForceMessage again = decodeForces(header, misalignedCopy(data, size, storage), agreed);
  if (!sameBits(forces.forces, again.forces)) finding(header, "Forces decoded differently from unaligned memory");
  requireCanonical(header, data, encodeForces(forces), {});
  // Another node count than the one agreed at the handshake must be refused.
  try {
    decodeForces(header, data, agreed + 1);
  } catch (const ProtocolError&) {
    return;
  }
  finding(header, "Forces accepted for a mesh of another node count");
}

void fuzzKinematics(const Header& header, const std::uint8_t* data, std::size_t size) {
  const std::size_t agreed = static_cast<std::size_t>(header.nodeCount);
  const NodalKinematics kinematics = decodeKinematics(header, data, agreed);
  try {
    kinematics.validate(agreed);
  } catch (const Error& error) {
    finding(header, std::string("accepted Kinematics fail validation: ") + error.what());
  }
  std::vector<std::uint8_t> storage;
  const NodalKinematics again = decodeKinematics(header, misalignedCopy(data, size, storage), agreed);
  if (!sameBits(kinematics.positions, again.positions) || !sameBits(kinematics.velocities, again.velocities) ||
      !sameBits(kinematics.accelerations, again.accelerations)) {
    finding(header, "Kinematics decoded differently from unaligned memory");
  }
  const auto encoded = encodeKinematics(header.window, kinematics, {}, header.iteration);
  if (agreed == 0) {
    requireCanonical(header, data, encoded, {flagsField}); // without nodes no array tells what the flags announced
  } else {
    requireCanonical(header, data, encoded, {});
  }
  try {
    decodeKinematics(header, data, agreed + 1);
  } catch (const ProtocolError&) {
    return;
  }
  finding(header, "Kinematics accepted for a mesh of another node count");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Header header;
  try {
    header = decodeHeader(data, size);
  } catch (const ProtocolError&) {
    return 0;
  }
  if (header.payloadBytes != size - headerBytes) finding(header, "decodeHeader accepted a payload size mismatch");
  try {
    switch (header.type) {
      case MessageType::Hello:
        fuzzHello(header, data);
        break;
      case MessageType::InterfaceMesh:
        fuzzMesh(header, data);
        break;
      case MessageType::Forces:
        fuzzForces(header, data, size);
        break;
      case MessageType::Kinematics:
        fuzzKinematics(header, data, size);
        break;
      case MessageType::Finalize:
        decodeFinalize(header);
        requireCanonical(header, data, encodeFinalize(header.window), {timeField});
        break;
      case MessageType::Abort: {
        const std::string reason = decodeAbort(header, data);
        requireCanonical(header, data, encodeAbort(header.window, reason), {timeField});
        break;
      }
      case MessageType::Checkpoint:
        fuzzCheckpoint(header, data);
        break;
      case MessageType::CheckpointWritten:
        fuzzCheckpointWritten(header, data);
        break;
      default:
        finding(header, "decodeHeader accepted an unknown message type");
    }
  } catch (const ProtocolError&) {
    // The documented outcome for a malformed body.
  } catch (const std::exception& error) {
    // Participant::decodeBody catches ProtocolError only: anything else skips the Abort to the peer.
    finding(header, std::string("a decoder threw something other than ProtocolError: ") + error.what());
  }
  return 0;
}
