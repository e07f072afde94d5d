// Encoding and validating decoding of bridge messages (little-endian, layout in docs/protocol.md).
#include "protocol/Message.hpp"
#include "railcosim/CouplingScheme.hpp"
#include "railcosim/Error.hpp"

#include <cctype>
#include <cmath>
#include <cstring>
#include <sstream>

namespace railcosim::protocol {
namespace {

/// A scheme name exactly as a participant announces it (the canonical spelling, nothing else).
bool isCanonicalScheme(const std::string& name) {
  try {
    return railcosim::toString(railcosim::parseCouplingScheme(name)) == name;
  } catch (const Error&) {
    return false;
  }
}

constexpr bool hostIsLittleEndian =
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    true;
#else
    false;
#endif

/// Whether `count` little-endian binary64 values (possibly unaligned) are all finite. Only the high
/// 32-bit word carries the exponent; testing it with 32-bit operations lets the loop vectorize with
/// plain SSE2, so the check costs about as much as one copy of the data.
bool allFinite(const std::uint8_t* bytes, std::size_t count) {
  constexpr std::uint32_t exponentMask = 0x7ff00000u; // all ones: NaN or infinity
  std::uint32_t nonFinite = 0;
  for (std::size_t i = 0; i < count; ++i) {
    std::uint32_t high;
    std::memcpy(&high, bytes + 8 * i + 4, 4);
    nonFinite |= (high & exponentMask) == exponentMask ? 1u : 0u;
  }
  return nonFinite == 0;
}

/// Appends little-endian values to a byte buffer sized once up front.
class Writer {
public:
  /// `reuse`: a buffer from an earlier message; its memory is kept, so large messages do not fault in new pages.
  Writer(std::size_t capacity, std::vector<std::uint8_t>&& reuse) : bytes_(std::move(reuse)) {
    bytes_.clear();
    bytes_.reserve(capacity);
  }
  void putU8(std::uint8_t value) { bytes_.push_back(value); }
  void putU16(std::uint16_t value) { putUnsigned(value, 2); }
  void putU32(std::uint32_t value) { putUnsigned(value, 4); }
  void putU64(std::uint64_t value) { putUnsigned(value, 8); }
  void putF64(double value) {
    std::uint64_t bits;
    std::memcpy(&bits, &value, 8);
    putU64(bits);
  }
  void putBytes(const void* data, std::size_t size) {
    const auto* begin = static_cast<const std::uint8_t*>(data);
    bytes_.insert(bytes_.end(), begin, begin + size);
  }
  /// Appends the array; returns false if a value is NaN or infinite (checked right after the copy, while the data are
  /// in cache).
  bool putF64Array(const std::vector<double>& values) {
    if (hostIsLittleEndian) {
      putBytes(values.data(), values.size() * sizeof(double));
      return allFinite(reinterpret_cast<const std::uint8_t*>(values.data()), values.size());
    }
    bool finite = true;
    for (double value : values) {
      finite = finite && std::isfinite(value);
      putF64(value);
    }
    return finite;
  }
  void putI32Array(const std::vector<std::int32_t>& values) {
    if (hostIsLittleEndian) {
      putBytes(values.data(), values.size() * sizeof(std::int32_t));
    } else {
      for (std::int32_t value : values) putU32(static_cast<std::uint32_t>(value));
    }
  }
  std::vector<std::uint8_t> take() { return std::move(bytes_); }

private:
  void putUnsigned(std::uint64_t value, int size) {
    for (int i = 0; i < size; ++i) bytes_.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
  }
  std::vector<std::uint8_t> bytes_;
};

/// Reads little-endian values; the caller has already checked the total size.
class Reader {
public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t u8() { return data_[advance(1)]; }
  std::uint16_t u16() { return static_cast<std::uint16_t>(unsignedValue(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(unsignedValue(4)); }
  std::uint64_t u64() { return unsignedValue(8); }
  double f64() {
    const std::uint64_t bits = u64();
    double value;
    std::memcpy(&value, &bits, 8);
    return value;
  }
  std::string text(std::size_t size) {
    const std::size_t at = advance(size);
    return std::string(reinterpret_cast<const char*>(data_ + at), size);
  }
  /// Reads `count` reals; returns false if one is NaN or infinite (checked right after the copy, while the data are in
  /// cache).
  bool f64Array(std::vector<double>& values, std::size_t count) {
    const std::size_t at = advance(count * sizeof(double));
    if (hostIsLittleEndian) {
      const std::uint8_t* source = data_ + at;
      if (reinterpret_cast<std::uintptr_t>(source) % alignof(double) == 0) {
        // The usual case (ZeroMQ buffers are malloc'ed, the header is 56 bytes): one copy, no zero-fill.
        const auto* first = reinterpret_cast<const double*>(source);
        values.assign(first, first + count);
      } else {
        values.resize(count);
        if (count > 0) std::memcpy(values.data(), source, count * sizeof(double));
      }
      return allFinite(source, count);
    }
    values.resize(count);
    Reader sub(data_ + at, count * sizeof(double));
    bool finite = true;
    for (auto& value : values) {
      value = sub.f64();
      finite = finite && std::isfinite(value);
    }
    return finite;
  }
  void i32Array(std::vector<std::int32_t>& values, std::size_t count) {
    values.resize(count);
    const std::size_t at = advance(count * sizeof(std::int32_t));
    if (hostIsLittleEndian) {
      if (count > 0) std::memcpy(values.data(), data_ + at, count * sizeof(std::int32_t));
    } else {
      Reader sub(data_ + at, count * sizeof(std::int32_t));
      for (auto& value : values) value = static_cast<std::int32_t>(sub.u32());
    }
  }
  std::size_t remaining() const { return size_ - position_; }

private:
  std::size_t advance(std::size_t size) {
    if (size > size_ - position_) {
      // Unreachable after the size checks in the decoders; kept so a logic slip cannot read past the end.
      throw ProtocolError("message is truncated: a field runs past the end of the message");
    }
    const std::size_t at = position_;
    position_ += size;
    return at;
  }
  std::uint64_t unsignedValue(int size) {
    const std::size_t at = advance(static_cast<std::size_t>(size));
    std::uint64_t value = 0;
    for (int i = 0; i < size; ++i) value |= static_cast<std::uint64_t>(data_[at + i]) << (8 * i);
    return value;
  }
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t position_ = 0;
};

void writeHeader(Writer& writer, const Header& header) {
  writer.putBytes(magic, 4);
  writer.putU16(header.version);
  writer.putU16(static_cast<std::uint16_t>(header.type));
  writer.putU64(header.window);
  writer.putU32(header.iteration);
  writer.putU32(header.flags);
  writer.putF64(header.time);
  writer.putU64(header.nodeCount);
  writer.putU64(header.triangleCount);
  writer.putU64(header.payloadBytes);
}

std::uint32_t kinematicsFlags(const NodalKinematics& kinematics) {
  return (kinematics.velocities.empty() ? 0u : flagVelocities) |
         (kinematics.accelerations.empty() ? 0u : flagAccelerations);
}

std::uint64_t kinematicsBytes(std::uint64_t nodes, std::uint32_t flags) {
  std::uint64_t arrays = 1;
  if (flags & flagVelocities) ++arrays;
  if (flags & flagAccelerations) ++arrays;
  return arrays * 3 * nodes * sizeof(double);
}

const char* componentName(std::size_t index) {
  static const char* names[3] = {"x", "y", "z"};
  return names[index % 3];
}

void requireFinite(const std::vector<double>& values, const std::string& message, const char* field) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      std::ostringstream text;
      text << message << ": field '" << field << "'[" << i << "] (node " << i / 3 << ", " << componentName(i) << ") is "
           << values[i] << "; the sender produced a non-finite value (diverged solution?)";
      throw ProtocolError(text.str());
    }
  }
}

void requireFiniteScalar(double value, const std::string& message, const char* field) {
  if (!std::isfinite(value)) {
    std::ostringstream text;
    text << message << ": field '" << field << "' is " << value << "; it must be finite";
    throw ProtocolError(text.str());
  }
}

void requireNoTriangles(const Header& header) {
  if (header.triangleCount != 0) {
    std::ostringstream text;
    text << describe(header) << ": field 'triangleCount' is " << header.triangleCount
         << " but only InterfaceMesh messages carry triangles";
    throw ProtocolError(text.str());
  }
}

void requireNoNodes(const Header& header) {
  if (header.nodeCount != 0) {
    std::ostringstream text;
    text << describe(header) << ": field 'nodeCount' is " << header.nodeCount
         << " but only InterfaceMesh, Forces and Kinematics messages carry nodes";
    throw ProtocolError(text.str());
  }
}

void requireFlags(const Header& header, std::uint32_t allowed) {
  if ((header.flags & ~allowed) != 0) {
    std::ostringstream text;
    text << describe(header) << ": field 'flags' = 0x" << std::hex << header.flags << std::dec
         << " has bits that protocol version " << protocolVersion << " does not define";
    throw ProtocolError(text.str());
  }
}

void requireNodeCount(const Header& header, std::size_t expectedNodes) {
  if (header.nodeCount != expectedNodes) {
    std::ostringstream text;
    text << describe(header) << ": field 'nodeCount' is " << header.nodeCount << " but the interface mesh agreed at "
         << "the handshake has " << expectedNodes << " nodes";
    throw ProtocolError(text.str());
  }
}

void requirePayload(const Header& header, std::uint64_t expected, const std::string& layout) {
  if (header.payloadBytes != expected) {
    std::ostringstream text;
    text << describe(header) << ": field 'payloadBytes' is " << header.payloadBytes << " but " << layout << " needs "
         << expected << " bytes";
    throw ProtocolError(text.str());
  }
}

void readKinematicsArrays(Reader& reader, const Header& header, NodalKinematics& kinematics) {
  const std::size_t values = static_cast<std::size_t>(3 * header.nodeCount);
  bool finite = reader.f64Array(kinematics.positions, values);
  if (header.flags & flagVelocities) finite = reader.f64Array(kinematics.velocities, values) && finite;
  if (header.flags & flagAccelerations) finite = reader.f64Array(kinematics.accelerations, values) && finite;
  if (!finite) {
    // Slow path, only to name the first bad value.
    const std::string what = describe(header);
    requireFinite(kinematics.positions, what, "positions");
    requireFinite(kinematics.velocities, what, "velocities");
    requireFinite(kinematics.accelerations, what, "accelerations");
  }
}

void writeKinematicsArrays(Writer& writer, const NodalKinematics& kinematics, const char* message) {
  bool finite = writer.putF64Array(kinematics.positions);
  if (!kinematics.velocities.empty()) finite = writer.putF64Array(kinematics.velocities) && finite;
  if (!kinematics.accelerations.empty()) finite = writer.putF64Array(kinematics.accelerations) && finite;
  if (!finite) {
    const std::string what = std::string("cannot encode ") + message;
    requireFinite(kinematics.positions, what, "positions");
    requireFinite(kinematics.velocities, what, "velocities");
    requireFinite(kinematics.accelerations, what, "accelerations");
  }
}

/// Why `name` cannot be a checkpoint folder name ("" when it can): it is joined to a folder on both sides.
std::string checkpointNameProblem(const std::string& name) {
  if (name.empty()) return "is empty";
  if (name[0] == '.') return "'" + name + "' starts with '.'";
  for (unsigned char c : name) {
    if (!std::isalnum(c) && c != '.' && c != '-' && c != '_')
      return "'" + name.substr(0, 80) + "' has a character other than letters, digits, '.', '-', '_'";
  }
  return "";
}

/// Why `text` is not a file list ("" when it is): printable text, fields separated by tabs, one file per line.
std::string fileListProblem(const std::string& text) {
  for (unsigned char c : text) {
    if ((c < 32 && c != '\t' && c != '\n') || c == 127) return "contains a control character";
  }
  return "";
}

std::string checkedText(const std::string& value, const char* field) {
  if (value.size() > maxTextBytes) {
    std::ostringstream text;
    text << "cannot encode field '" << field << "': " << value.size() << " bytes, the protocol allows at most "
         << maxTextBytes;
    throw ProtocolError(text.str());
  }
  return value;
}

} // namespace

std::string toString(MessageType type) {
  switch (type) {
    case MessageType::Hello:
      return "Hello";
    case MessageType::InterfaceMesh:
      return "InterfaceMesh";
    case MessageType::Forces:
      return "Forces";
    case MessageType::Kinematics:
      return "Kinematics";
    case MessageType::Finalize:
      return "Finalize";
    case MessageType::Abort:
      return "Abort";
    case MessageType::Checkpoint:
      return "Checkpoint";
    case MessageType::CheckpointWritten:
      return "CheckpointWritten";
  }
  return "type " + std::to_string(static_cast<unsigned>(type));
}

std::string toString(Role role) {
  switch (role) {
    case Role::Fem:
      return "fem";
    case Role::Dem:
      return "dem";
  }
  return "role " + std::to_string(static_cast<unsigned>(role));
}

std::string describe(const Header& header) {
  switch (header.type) {
    case MessageType::Forces:
    case MessageType::Kinematics:
    case MessageType::Checkpoint:
    case MessageType::CheckpointWritten:
      return toString(header.type) + " for window " + std::to_string(header.window) +
             (header.iteration > 0 ? " (iteration " + std::to_string(header.iteration) + ")" : std::string());
    default:
      return toString(header.type);
  }
}

std::vector<std::uint8_t> encodeHello(const Hello& hello, std::uint16_t version, std::vector<std::uint8_t> buffer) {
  const std::string name = checkedText(hello.participantName, "participantName");
  const std::string units = checkedText(hello.unitSystem, "unitSystem");
  const std::string scheme = checkedText(hello.couplingScheme, "couplingScheme");
  const std::string resumedFrom = checkedText(hello.resumedFrom, "resumedFrom");
  if (!resumedFrom.empty()) {
    const std::string problem = checkpointNameProblem(resumedFrom);
    if (!problem.empty()) throw ProtocolError("cannot encode Hello: field 'resumedFrom' " + problem);
  } else if (hello.resumedWindow != 0) {
    throw ProtocolError("cannot encode Hello: a resumed window without the checkpoint it comes from");
  }
  Header header;
  header.version = version;
  header.type = MessageType::Hello;
  header.window = hello.resumedWindow;
  header.payloadBytes = 1 + 2 + name.size() + 2 + units.size() + 2 + scheme.size() + 2 + resumedFrom.size();
  Writer writer(headerBytes + header.payloadBytes, std::move(buffer));
  writeHeader(writer, header);
  writer.putU8(static_cast<std::uint8_t>(hello.role));
  writer.putU16(static_cast<std::uint16_t>(name.size()));
  writer.putBytes(name.data(), name.size());
  writer.putU16(static_cast<std::uint16_t>(units.size()));
  writer.putBytes(units.data(), units.size());
  writer.putU16(static_cast<std::uint16_t>(scheme.size()));
  writer.putBytes(scheme.data(), scheme.size());
  writer.putU16(static_cast<std::uint16_t>(resumedFrom.size()));
  writer.putBytes(resumedFrom.data(), resumedFrom.size());
  return writer.take();
}

std::vector<std::uint8_t> encodeMesh(const InterfaceMesh& mesh, double femTimeStep, const NodalKinematics& initial,
                                     std::vector<std::uint8_t> buffer) {
  Header header;
  header.type = MessageType::InterfaceMesh;
  header.time = initial.time;
  header.flags = kinematicsFlags(initial);
  header.nodeCount = mesh.nodeCount();
  header.triangleCount = mesh.triangleCount();
  header.payloadBytes = sizeof(double) + mesh.coordinates.size() * sizeof(double) +
                        mesh.triangles.size() * sizeof(std::int32_t) + kinematicsBytes(header.nodeCount, header.flags);
  Writer writer(headerBytes + header.payloadBytes, std::move(buffer));
  writeHeader(writer, header);
  writer.putF64(femTimeStep);
  if (!writer.putF64Array(mesh.coordinates))
    requireFinite(mesh.coordinates, "cannot encode InterfaceMesh", "coordinates");
  writer.putI32Array(mesh.triangles);
  writeKinematicsArrays(writer, initial, "InterfaceMesh");
  return writer.take();
}

std::vector<std::uint8_t> encodeForces(const ForceMessage& message, std::vector<std::uint8_t> buffer) {
  Header header;
  header.type = MessageType::Forces;
  header.window = message.window;
  header.iteration = message.iteration;
  header.time = message.time;
  header.nodeCount = message.forces.size() / 3;
  header.payloadBytes = message.forces.size() * sizeof(double);
  Writer writer(headerBytes + header.payloadBytes, std::move(buffer));
  writeHeader(writer, header);
  if (!writer.putF64Array(message.forces)) {
    requireFinite(message.forces, "cannot encode Forces for window " + std::to_string(message.window), "forces");
  }
  return writer.take();
}

std::vector<std::uint8_t> encodeKinematics(std::uint64_t window, const NodalKinematics& kinematics,
                                           std::vector<std::uint8_t> buffer, std::uint32_t iteration) {
  Header header;
  header.type = MessageType::Kinematics;
  header.window = window;
  header.iteration = iteration;
  header.time = kinematics.time;
  header.flags = kinematicsFlags(kinematics);
  header.nodeCount = kinematics.positions.size() / 3;
  header.payloadBytes = kinematicsBytes(header.nodeCount, header.flags);
  Writer writer(headerBytes + header.payloadBytes, std::move(buffer));
  writeHeader(writer, header);
  writeKinematicsArrays(writer, kinematics, ("Kinematics for window " + std::to_string(window)).c_str());
  return writer.take();
}

std::vector<std::uint8_t> encodeFinalize(std::uint64_t window, std::vector<std::uint8_t> buffer) {
  Header header;
  header.type = MessageType::Finalize;
  header.window = window;
  Writer writer(headerBytes, std::move(buffer));
  writeHeader(writer, header);
  return writer.take();
}

std::vector<std::uint8_t> encodeAbort(std::uint64_t window, const std::string& reason,
                                      std::vector<std::uint8_t> buffer) {
  // A reason longer than the limit is cut rather than refused: an abort must always go out.
  const std::string text = reason.substr(0, maxTextBytes);
  Header header;
  header.type = MessageType::Abort;
  header.window = window;
  header.payloadBytes = text.size();
  Writer writer(headerBytes + text.size(), std::move(buffer));
  writeHeader(writer, header);
  writer.putBytes(text.data(), text.size());
  return writer.take();
}

std::vector<std::uint8_t> encodeCheckpoint(const CheckpointOrder& order, std::vector<std::uint8_t> buffer) {
  const std::string name = checkedText(order.name, "name");
  const std::string problem = checkpointNameProblem(name);
  if (!problem.empty()) throw ProtocolError("cannot encode Checkpoint: field 'name' " + problem);
  requireFiniteScalar(order.time, "cannot encode Checkpoint", "time");
  Header header;
  header.type = MessageType::Checkpoint;
  header.window = order.window;
  header.time = order.time;
  header.payloadBytes = name.size();
  Writer writer(headerBytes + header.payloadBytes, std::move(buffer));
  writeHeader(writer, header);
  writer.putBytes(name.data(), name.size());
  return writer.take();
}

std::vector<std::uint8_t> encodeCheckpointWritten(std::uint64_t window, const std::string& files,
                                                  std::vector<std::uint8_t> buffer) {
  const std::string text = checkedText(files, "files");
  const std::string problem = fileListProblem(text);
  if (!problem.empty()) throw ProtocolError("cannot encode CheckpointWritten: field 'files' " + problem);
  Header header;
  header.type = MessageType::CheckpointWritten;
  header.window = window;
  header.payloadBytes = text.size();
  Writer writer(headerBytes + header.payloadBytes, std::move(buffer));
  writeHeader(writer, header);
  writer.putBytes(text.data(), text.size());
  return writer.take();
}

Header decodeHeader(const std::uint8_t* data, std::size_t size) {
  std::ostringstream text;
  // Magic and version sit at fixed offsets in every protocol version, so a mismatch is always reported as such.
  if (size < 6) {
    text << "message of " << size << " bytes is truncated: even the magic and version (6 bytes) are missing";
    throw ProtocolError(text.str());
  }
  if (std::memcmp(data, magic, 4) != 0) {
    text << "field 'magic' is not \"RCSM\" (bytes 0x" << std::hex;
    for (int i = 0; i < 4; ++i) text << (data[i] < 16 ? "0" : "") << static_cast<unsigned>(data[i]);
    text << std::dec << "); the peer is not a railcosim bridge or the endpoint is shared with another program";
    throw ProtocolError(text.str());
  }
  Reader reader(data + 4, size - 4);
  Header header;
  header.version = reader.u16();
  if (header.version != protocolVersion) {
    text << "field 'version': protocol version mismatch, the peer speaks version " << header.version
         << " and this side speaks version " << protocolVersion
         << "; build both participants from the same railcosim release";
    throw ProtocolError(text.str());
  }
  if (size < headerBytes) {
    text << "message of " << size << " bytes is truncated: the header alone needs " << headerBytes << " bytes";
    throw ProtocolError(text.str());
  }
  const std::uint16_t type = reader.u16();
  if (type < static_cast<std::uint16_t>(MessageType::Hello) ||
      type > static_cast<std::uint16_t>(MessageType::CheckpointWritten)) {
    text << "field 'type' = " << type << " is not a message type of protocol version " << protocolVersion;
    throw ProtocolError(text.str());
  }
  header.type = static_cast<MessageType>(type);
  header.window = reader.u64();
  header.iteration = reader.u32();
  header.flags = reader.u32();
  header.time = reader.f64();
  header.nodeCount = reader.u64();
  header.triangleCount = reader.u64();
  header.payloadBytes = reader.u64();
  if (header.iteration != 0 && header.type != MessageType::Forces && header.type != MessageType::Kinematics) {
    text << describe(header) << ": field 'iteration' is " << header.iteration
         << "; only Forces and Kinematics carry an implicit-coupling iteration, other messages need 0";
    throw ProtocolError(text.str());
  }
  requireFiniteScalar(header.time, describe(header), "time");
  if (header.nodeCount > maxNodes || header.triangleCount > maxTriangles) {
    text << describe(header) << ": field 'nodeCount' = " << header.nodeCount
         << " or 'triangleCount' = " << header.triangleCount << " exceeds the protocol limits (" << maxNodes << ", "
         << maxTriangles << ")";
    throw ProtocolError(text.str());
  }
  const std::uint64_t received = size - headerBytes;
  if (header.payloadBytes != received) {
    text << describe(header) << " is " << (received < header.payloadBytes ? "truncated" : "oversized")
         << ": field 'payloadBytes' announces " << header.payloadBytes << " bytes after the header, " << received
         << " arrived";
    throw ProtocolError(text.str());
  }
  return header;
}

Hello decodeHello(const Header& header, const std::uint8_t* data) {
  requireNoNodes(header);
  requireNoTriangles(header);
  requireFlags(header, 0);
  std::ostringstream text;
  Reader reader(data + headerBytes, header.payloadBytes);
  auto needBytes = [&](std::size_t count, const char* field) {
    if (reader.remaining() < count) {
      text << "Hello is truncated: field '" << field << "' needs " << count << " bytes, " << reader.remaining()
           << " remain";
      throw ProtocolError(text.str());
    }
  };
  Hello hello;
  needBytes(1, "role");
  const std::uint8_t role = reader.u8();
  if (role != static_cast<std::uint8_t>(Role::Fem) && role != static_cast<std::uint8_t>(Role::Dem)) {
    text << "Hello: field 'role' = " << static_cast<unsigned>(role) << " is neither fem (1) nor dem (2)";
    throw ProtocolError(text.str());
  }
  hello.role = static_cast<Role>(role);
  needBytes(2, "participantName length");
  const std::size_t nameSize = reader.u16();
  needBytes(nameSize, "participantName");
  hello.participantName = reader.text(nameSize);
  needBytes(2, "unitSystem length");
  const std::size_t unitSize = reader.u16();
  needBytes(unitSize, "unitSystem");
  hello.unitSystem = reader.text(unitSize);
  needBytes(2, "couplingScheme length");
  const std::size_t schemeSize = reader.u16();
  needBytes(schemeSize, "couplingScheme");
  hello.couplingScheme = reader.text(schemeSize);
  needBytes(2, "resumedFrom length");
  const std::size_t resumedSize = reader.u16();
  needBytes(resumedSize, "resumedFrom");
  hello.resumedFrom = reader.text(resumedSize);
  hello.resumedWindow = header.window;
  if (reader.remaining() != 0) {
    text << "Hello is oversized: " << reader.remaining() << " bytes follow field 'resumedFrom'";
    throw ProtocolError(text.str());
  }
  if (hello.participantName.empty()) throw ProtocolError("Hello: field 'participantName' is empty");
  for (unsigned char c : hello.participantName) {
    if (c < 32 || c == 127) throw ProtocolError("Hello: field 'participantName' contains a control character");
  }
  if (!hello.couplingScheme.empty() && !isCanonicalScheme(hello.couplingScheme)) {
    throw ProtocolError("Hello from '" + hello.participantName + "': field 'couplingScheme' is '" +
                        hello.couplingScheme + "'; expected " + knownCouplingSchemes() + " or empty");
  }
  if (hello.unitSystem != "SI") {
    throw ProtocolError("Hello from '" + hello.participantName + "': field 'unitSystem' is '" + hello.unitSystem +
                        "'; this side works in SI units (m, kg, s, N) only");
  }
  if (!hello.resumedFrom.empty()) {
    const std::string problem = checkpointNameProblem(hello.resumedFrom);
    if (!problem.empty())
      throw ProtocolError("Hello from '" + hello.participantName + "': field 'resumedFrom' " + problem);
  } else if (hello.resumedWindow != 0) {
    throw ProtocolError("Hello from '" + hello.participantName + "': field 'window' is " +
                        std::to_string(hello.resumedWindow) +
                        " but field 'resumedFrom' is empty (a fresh start has window 0)");
  }
  return hello;
}

MeshSetup decodeMesh(const Header& header, const std::uint8_t* data) {
  requireFlags(header, flagVelocities | flagAccelerations);
  std::ostringstream text;
  if (header.nodeCount == 0 || header.triangleCount == 0) {
    text << "InterfaceMesh: field 'nodeCount' = " << header.nodeCount << ", 'triangleCount' = " << header.triangleCount
         << "; the coupled surface needs at least 3 nodes and 1 triangle";
    throw ProtocolError(text.str());
  }
  if (header.nodeCount > static_cast<std::uint64_t>(INT32_MAX)) {
    text << "InterfaceMesh: field 'nodeCount' = " << header.nodeCount << " exceeds the int32 triangle indices";
    throw ProtocolError(text.str());
  }
  const std::uint64_t expected = sizeof(double) + 3 * header.nodeCount * sizeof(double) +
                                 3 * header.triangleCount * sizeof(std::int32_t) +
                                 kinematicsBytes(header.nodeCount, header.flags);
  requirePayload(header, expected, "femTimeStep + coordinates + triangles + initial kinematics");
  Reader reader(data + headerBytes, header.payloadBytes);
  MeshSetup setup;
  setup.femTimeStep = reader.f64();
  if (!(setup.femTimeStep > 0.0) || !std::isfinite(setup.femTimeStep)) {
    text << "InterfaceMesh: field 'femTimeStep' = " << setup.femTimeStep << " s; it must be positive and finite";
    throw ProtocolError(text.str());
  }
  if (!reader.f64Array(setup.mesh.coordinates, static_cast<std::size_t>(3 * header.nodeCount))) {
    requireFinite(setup.mesh.coordinates, "InterfaceMesh", "coordinates");
  }
  reader.i32Array(setup.mesh.triangles, static_cast<std::size_t>(3 * header.triangleCount));
  for (std::size_t i = 0; i < setup.mesh.triangles.size(); ++i) {
    const std::int32_t index = setup.mesh.triangles[i];
    if (index < 0 || static_cast<std::uint64_t>(index) >= header.nodeCount) {
      text << "InterfaceMesh: field 'triangles'[" << i << "] (triangle " << i / 3 << ", corner " << i % 3
           << ") = " << index << " is out of range [0, " << header.nodeCount << ")";
      throw ProtocolError(text.str());
    }
  }
  setup.initial.time = header.time;
  readKinematicsArrays(reader, header, setup.initial);
  try {
    setup.mesh.validate();
  } catch (const ProtocolError&) {
    throw;
  } catch (const Error& error) {
    throw ProtocolError(std::string("InterfaceMesh received from the peer is invalid: ") + error.what());
  }
  return setup;
}

ForceMessage decodeForces(const Header& header, const std::uint8_t* data, std::size_t expectedNodes) {
  requireNoTriangles(header);
  requireFlags(header, 0);
  requireNodeCount(header, expectedNodes);
  requirePayload(header, 3 * header.nodeCount * sizeof(double), "3 force components per node");
  Reader reader(data + headerBytes, header.payloadBytes);
  ForceMessage message;
  message.window = header.window;
  message.iteration = header.iteration;
  message.time = header.time;
  if (!reader.f64Array(message.forces, static_cast<std::size_t>(3 * header.nodeCount))) {
    requireFinite(message.forces, describe(header), "forces");
  }
  return message;
}

NodalKinematics decodeKinematics(const Header& header, const std::uint8_t* data, std::size_t expectedNodes) {
  requireNoTriangles(header);
  requireFlags(header, flagVelocities | flagAccelerations);
  requireNodeCount(header, expectedNodes);
  requirePayload(header, kinematicsBytes(header.nodeCount, header.flags),
                 "positions (+ velocities, accelerations as flagged)");
  Reader reader(data + headerBytes, header.payloadBytes);
  NodalKinematics kinematics;
  kinematics.time = header.time;
  readKinematicsArrays(reader, header, kinematics);
  return kinematics;
}

std::string decodeAbort(const Header& header, const std::uint8_t* data) {
  requireNoNodes(header);
  requireNoTriangles(header);
  requireFlags(header, 0);
  if (header.payloadBytes > maxTextBytes) {
    std::ostringstream text;
    text << "Abort: field 'payloadBytes' = " << header.payloadBytes << " exceeds the reason limit of " << maxTextBytes
         << " bytes";
    throw ProtocolError(text.str());
  }
  return std::string(reinterpret_cast<const char*>(data + headerBytes), static_cast<std::size_t>(header.payloadBytes));
}

void decodeFinalize(const Header& header) {
  requireNoTriangles(header);
  requireFlags(header, 0);
  requireNoNodes(header);
  requirePayload(header, 0, "a Finalize message (no payload)");
}

CheckpointOrder decodeCheckpoint(const Header& header, const std::uint8_t* data) {
  requireNoNodes(header);
  requireNoTriangles(header);
  requireFlags(header, 0);
  if (header.payloadBytes > maxTextBytes) {
    std::ostringstream text;
    text << describe(header) << ": field 'payloadBytes' = " << header.payloadBytes << " exceeds the name limit of "
         << maxTextBytes << " bytes";
    throw ProtocolError(text.str());
  }
  CheckpointOrder order;
  order.window = header.window;
  order.time = header.time;
  order.name.assign(reinterpret_cast<const char*>(data + headerBytes), static_cast<std::size_t>(header.payloadBytes));
  const std::string problem = checkpointNameProblem(order.name);
  if (!problem.empty()) throw ProtocolError(describe(header) + ": field 'name' " + problem);
  return order;
}

std::string decodeCheckpointWritten(const Header& header, const std::uint8_t* data) {
  requireNoNodes(header);
  requireNoTriangles(header);
  requireFlags(header, 0);
  if (header.payloadBytes > maxTextBytes) {
    std::ostringstream text;
    text << describe(header) << ": field 'payloadBytes' = " << header.payloadBytes << " exceeds the file list limit of "
         << maxTextBytes << " bytes";
    throw ProtocolError(text.str());
  }
  std::string files(reinterpret_cast<const char*>(data + headerBytes), static_cast<std::size_t>(header.payloadBytes));
  const std::string problem = fileListProblem(files);
  if (!problem.empty()) throw ProtocolError(describe(header) + ": field 'files' " + problem);
  return files;
}

} // namespace railcosim::protocol
