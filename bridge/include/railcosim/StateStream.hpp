// Solver and scheme state for restart checkpoints: named sections of tagged little-endian values, reals bit for bit.
#pragma once

#include "railcosim/InterfaceMesh.hpp"

#include <cstdint>
#include <istream>
#include <ostream>
#include <string>
#include <vector>

namespace railcosim {

/// Writes a state as named sections of typed values. Every value carries a one-byte type tag and every section its
/// name, so that a reader expecting another layout (another release, another scheme) stops at the first difference
/// and names it instead of reading garbage. Reals are stored as their IEEE-754 bits: a restored state is the saved
/// one bit for bit.
class StateWriter {
public:
  explicit StateWriter(std::ostream& out);
  void section(const std::string& name);
  void u64(std::uint64_t value);
  void i64(std::int64_t value);
  void real(double value);
  void flag(bool value);
  void text(const std::string& value);
  void reals(const std::vector<double>& values);
  void bytes(const std::string& values); // an opaque blob (e.g. another writer's whole output)
  void kinematics(const NodalKinematics& value);

private:
  void tag(char type);
  void raw(std::uint64_t value, int size);
  std::ostream& out_;
};

/// Reads what a StateWriter wrote, in the same order. Any difference (section name, value type, a stream cut
/// short) throws CheckpointError naming `source` (e.g. the file), the section and what was expected.
class StateReader {
public:
  StateReader(std::istream& in, std::string source);
  void section(const std::string& name);
  std::uint64_t u64();
  std::int64_t i64();
  double real();
  bool flag();
  std::string text();
  std::vector<double> reals();
  std::string bytes();
  NodalKinematics kinematics();
  const std::string& source() const { return source_; }
  /// Throws CheckpointError naming the source, the current section and `problem`.
  [[noreturn]] void fail(const std::string& problem) const;

private:
  void expect(char type, const char* what);
  std::uint64_t raw(int size);
  std::istream& in_;
  std::string source_;
  std::string section_ = "(start)";
};

} // namespace railcosim
