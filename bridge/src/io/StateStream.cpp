// StateWriter / StateReader: the binary layout of checkpointed state (tag byte, little-endian value).
#include "railcosim/StateStream.hpp"
#include "railcosim/Error.hpp"

#include <cstring>
#include <limits>

namespace railcosim {
namespace {

// Type tags: one letter each, so that a hex dump of a state file is readable.
constexpr char sectionTag = 'S', u64Tag = 'U', i64Tag = 'I', realTag = 'R', flagTag = 'B', textTag = 'T',
               realsTag = 'V', bytesTag = 'X';
// No checkpointed array or text comes near this; a larger count is a corrupt stream, not an allocation to try.
constexpr std::uint64_t maxCount = std::uint64_t(1) << 36;

const char* tagName(char tag) {
  switch (tag) {
    case sectionTag:
      return "a section";
    case u64Tag:
      return "an unsigned integer";
    case i64Tag:
      return "an integer";
    case realTag:
      return "a real";
    case flagTag:
      return "a flag";
    case textTag:
      return "a text";
    case realsTag:
      return "an array of reals";
    case bytesTag:
      return "a blob";
  }
  return "an unknown value";
}

} // namespace

StateWriter::StateWriter(std::ostream& out) : out_(out) {}

void StateWriter::tag(char type) { out_.put(type); }

void StateWriter::raw(std::uint64_t value, int size) {
  char bytes[8];
  for (int i = 0; i < size; ++i) bytes[i] = static_cast<char>(value >> (8 * i));
  out_.write(bytes, size);
}

void StateWriter::section(const std::string& name) {
  tag(sectionTag);
  raw(name.size(), 8);
  out_.write(name.data(), static_cast<std::streamsize>(name.size()));
}

void StateWriter::u64(std::uint64_t value) {
  tag(u64Tag);
  raw(value, 8);
}

void StateWriter::i64(std::int64_t value) {
  tag(i64Tag);
  raw(static_cast<std::uint64_t>(value), 8);
}

void StateWriter::real(double value) {
  tag(realTag);
  std::uint64_t bits;
  std::memcpy(&bits, &value, 8);
  raw(bits, 8);
}

void StateWriter::flag(bool value) {
  tag(flagTag);
  raw(value ? 1 : 0, 1);
}

void StateWriter::text(const std::string& value) {
  tag(textTag);
  raw(value.size(), 8);
  out_.write(value.data(), static_cast<std::streamsize>(value.size()));
}

void StateWriter::reals(const std::vector<double>& values) {
  tag(realsTag);
  raw(values.size(), 8);
  for (double value : values) {
    std::uint64_t bits;
    std::memcpy(&bits, &value, 8);
    raw(bits, 8);
  }
}

void StateWriter::bytes(const std::string& values) {
  tag(bytesTag);
  raw(values.size(), 8);
  out_.write(values.data(), static_cast<std::streamsize>(values.size()));
}

void StateWriter::kinematics(const NodalKinematics& value) {
  real(value.time);
  reals(value.positions);
  reals(value.velocities);
  reals(value.accelerations);
}

StateReader::StateReader(std::istream& in, std::string source) : in_(in), source_(std::move(source)) {}

void StateReader::fail(const std::string& problem) const {
  throw CheckpointError("checkpoint state " + source_ + ", section '" + section_ + "': " + problem +
                        "; the state was written by another railcosim release or set-up, or the file is damaged");
}

std::uint64_t StateReader::raw(int size) {
  unsigned char bytes[8] = {0};
  if (!in_.read(reinterpret_cast<char*>(bytes), size)) fail("the data end early");
  std::uint64_t value = 0;
  for (int i = 0; i < size; ++i) value |= static_cast<std::uint64_t>(bytes[i]) << (8 * i);
  return value;
}

void StateReader::expect(char type, const char* what) {
  const int found = in_.get();
  if (found == std::char_traits<char>::eof()) fail(std::string("the data end where ") + what + " was expected");
  if (static_cast<char>(found) != type)
    fail(std::string("expected ") + tagName(type) + " (" + what + "), found " + tagName(static_cast<char>(found)));
}

void StateReader::section(const std::string& name) {
  expect(sectionTag, ("section '" + name + "'").c_str());
  const std::uint64_t size = raw(8);
  if (size > 4096) fail("a section name of " + std::to_string(size) + " bytes");
  std::string found(size, '\0');
  if (size > 0 && !in_.read(&found[0], static_cast<std::streamsize>(size))) fail("the data end early");
  if (found != name) fail("expected section '" + name + "', found '" + found + "'");
  section_ = name;
}

std::uint64_t StateReader::u64() {
  expect(u64Tag, "an unsigned integer");
  return raw(8);
}

std::int64_t StateReader::i64() {
  expect(i64Tag, "an integer");
  return static_cast<std::int64_t>(raw(8));
}

double StateReader::real() {
  expect(realTag, "a real");
  const std::uint64_t bits = raw(8);
  double value;
  std::memcpy(&value, &bits, 8);
  return value;
}

bool StateReader::flag() {
  expect(flagTag, "a flag");
  const std::uint64_t value = raw(1);
  if (value > 1) fail("a flag of value " + std::to_string(value));
  return value == 1;
}

std::string StateReader::text() {
  expect(textTag, "a text");
  const std::uint64_t size = raw(8);
  if (size > maxCount) fail("a text of " + std::to_string(size) + " bytes");
  std::string value(size, '\0');
  if (size > 0 && !in_.read(&value[0], static_cast<std::streamsize>(size))) fail("the data end inside a text");
  return value;
}

std::vector<double> StateReader::reals() {
  expect(realsTag, "an array of reals");
  const std::uint64_t count = raw(8);
  if (count > maxCount) fail("an array of " + std::to_string(count) + " reals");
  std::vector<double> values(count);
  for (double& value : values) {
    const std::uint64_t bits = raw(8);
    std::memcpy(&value, &bits, 8);
  }
  return values;
}

std::string StateReader::bytes() {
  expect(bytesTag, "a blob");
  const std::uint64_t size = raw(8);
  if (size > maxCount) fail("a blob of " + std::to_string(size) + " bytes");
  std::string value(size, '\0');
  if (size > 0 && !in_.read(&value[0], static_cast<std::streamsize>(size))) fail("the data end inside a blob");
  return value;
}

NodalKinematics StateReader::kinematics() {
  NodalKinematics value;
  value.time = real();
  value.positions = reals();
  value.velocities = reals();
  value.accelerations = reals();
  return value;
}

} // namespace railcosim
