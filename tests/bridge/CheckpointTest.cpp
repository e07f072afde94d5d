// Restart checkpoint files: the state stream (bit for bit, refusals naming the section) and checkpoint folders
// (manifest written last, CRC-32, pruning, verification refusals).
#define BOOST_TEST_MODULE bridge_Checkpoint
#include <boost/test/unit_test.hpp>

#include "protocol/Message.hpp"
#include "railcosim/Checkpoint.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/StateStream.hpp"

#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

using namespace railcosim;
namespace fs = std::filesystem;

namespace {

/// Expects CheckpointError whose message contains every one of `fragments`.
template <class Call>
void expectRefused(Call call, std::initializer_list<const char*> fragments) {
  try {
    call();
  } catch (const CheckpointError& error) {
    const std::string message = error.what();
    BOOST_TEST(message.find('\n') == std::string::npos, "one line: " << message);
    for (const char* fragment : fragments) {
      BOOST_TEST_INFO("message: " << message);
      BOOST_TEST(message.find(fragment) != std::string::npos, "missing '" << fragment << "'");
    }
    return;
  }
  BOOST_FAIL("no CheckpointError thrown");
}

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// A fresh folder under /tmp, removed at the end of the test.
struct Scratch {
  fs::path root = fs::temp_directory_path() /
                  ("railcosim-checkpoint-test-" + std::to_string(getpid()) + "-" + std::to_string(counter++));
  Scratch() { fs::create_directories(root); }
  ~Scratch() { fs::remove_all(root); }
  static inline int counter = 0;
};

void writeFile(const fs::path& path, const std::string& content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << content;
}

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream content;
  content << in.rdbuf();
  return content.str();
}

/// A checkpoint of both sides committed under `root` after `window` windows.
CheckpointManifest commitSample(const fs::path& root, std::uint64_t window) {
  const std::string name = checkpointName(window);
  const std::string staging = prepareCheckpoint(root.string(), name);
  writeFile(fs::path(staging) / "fem_state.bin", "fem state of window " + std::to_string(window));
  writeFile(fs::path(staging) / "dem_state.bin", "dem state of window " + std::to_string(window));
  CheckpointManifest manifest;
  manifest.name = name;
  manifest.window = window;
  manifest.time = 5e-4 * static_cast<double>(window);
  manifest.scheme = "predictive";
  manifest.run = "case=test";
  manifest.files = {describeCheckpointFile(staging, "fem_state.bin", "fem"),
                    describeCheckpointFile(staging, "dem_state.bin", "dem")};
  commitCheckpoint(root.string(), manifest);
  return manifest;
}

} // namespace

BOOST_AUTO_TEST_CASE(state_stream_round_trip_is_bit_for_bit) {
  const double values[] = {0.1,
                           -0.0,
                           std::numeric_limits<double>::denorm_min(),
                           std::numeric_limits<double>::max(),
                           std::numeric_limits<double>::infinity(),
                           1.0 / 3.0};
  std::ostringstream out;
  StateWriter writer(out);
  writer.section("values");
  for (double v : values) writer.real(v);
  writer.u64(std::numeric_limits<std::uint64_t>::max());
  writer.i64(-42);
  writer.flag(true);
  writer.text(std::string("tab\there\nand a NUL \0 inside", 27));
  writer.reals({1e-300, -2.5, 7.0});
  writer.bytes(std::string("\x00\x01\xff", 3));
  NodalKinematics kinematics;
  kinematics.time = 0.125;
  kinematics.positions = {1, 2, 3};
  kinematics.accelerations = {-9.81, 0, 0};
  writer.kinematics(kinematics);

  std::istringstream in(out.str());
  StateReader reader(in, "test");
  reader.section("values");
  for (double v : values) BOOST_TEST(sameBits(reader.real(), v));
  BOOST_TEST(reader.u64() == std::numeric_limits<std::uint64_t>::max());
  BOOST_TEST(reader.i64() == -42);
  BOOST_TEST(reader.flag());
  BOOST_TEST(reader.text() == std::string("tab\there\nand a NUL \0 inside", 27));
  BOOST_TEST(reader.reals() == std::vector<double>({1e-300, -2.5, 7.0}));
  BOOST_TEST(reader.bytes() == std::string("\x00\x01\xff", 3));
  const NodalKinematics back = reader.kinematics();
  BOOST_TEST(back.time == 0.125);
  BOOST_TEST(back.positions == kinematics.positions);
  BOOST_TEST(back.velocities.empty());
  BOOST_TEST(back.accelerations == kinematics.accelerations);
}

BOOST_AUTO_TEST_CASE(state_stream_refuses_another_layout_naming_the_section) {
  std::ostringstream out;
  StateWriter writer(out);
  writer.section("dem coupling scheme");
  writer.text("predictive");
  writer.u64(7);
  {
    std::istringstream in(out.str());
    StateReader reader(in, "of the test");
    expectRefused([&] { reader.section("fem coupling scheme"); },
                  {"of the test", "expected section 'fem coupling scheme', found 'dem coupling scheme'"});
  }
  {
    std::istringstream in(out.str());
    StateReader reader(in, "of the test");
    reader.section("dem coupling scheme");
    expectRefused([&] { reader.real(); }, {"section 'dem coupling scheme'", "expected a real", "found a text"});
  }
  {
    std::istringstream in(out.str().substr(0, out.str().size() - 3)); // cut short
    StateReader reader(in, "of the test");
    reader.section("dem coupling scheme");
    reader.text();
    expectRefused([&] { reader.u64(); }, {"the data end early"});
  }
}

BOOST_AUTO_TEST_CASE(crc32_is_that_of_iso_3309) {
  Scratch scratch;
  writeFile(scratch.root / "check", "123456789");
  const CheckpointFile file = describeCheckpointFile(scratch.root.string(), "check", "dem");
  BOOST_TEST(file.crc32 == 0xcbf43926u); // the standard check value, as zlib.crc32(b"123456789")
  BOOST_TEST(file.bytes == 9u);
}

BOOST_AUTO_TEST_CASE(commit_writes_the_manifest_last_and_keeps_the_newest_two) {
  Scratch scratch;
  BOOST_TEST(latestCheckpoint(scratch.root.string()).empty());
  commitSample(scratch.root, 100);
  commitSample(scratch.root, 200);
  // An interrupted save leaves its staging folder, manifest or not; it is never complete.
  const std::string interrupted = prepareCheckpoint(scratch.root.string(), checkpointName(300));
  writeFile(fs::path(interrupted) / "manifest.json", "{}");
  BOOST_TEST(latestCheckpoint(scratch.root.string()) == (scratch.root / "window-00000200").string());
  const CheckpointManifest manifest = commitSample(scratch.root, 400);
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(scratch.root)) names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  BOOST_TEST(names == std::vector<std::string>({"window-00000200", "window-00000400"}));
  const CheckpointManifest read = verifyCheckpoint((scratch.root / "window-00000400").string());
  BOOST_TEST(read.name == "window-00000400");
  BOOST_TEST(read.protocolVersion == protocol::protocolVersion);
  BOOST_TEST(read.window == 400u);
  BOOST_TEST(read.time == manifest.time); // written with 17 digits: the same double
  BOOST_TEST(read.scheme == "predictive");
  BOOST_TEST(read.run == "case=test");
  BOOST_TEST(read.files.size() == 2u);
  BOOST_TEST(read.files[0].crc32 == manifest.files[0].crc32);
}

BOOST_AUTO_TEST_CASE(verification_refuses_in_one_line) {
  Scratch scratch;
  commitSample(scratch.root, 100);
  const fs::path folder = scratch.root / "window-00000100";
  const std::string manifest = readFile(folder / "manifest.json");
  expectRefused([&] { verifyCheckpoint((scratch.root / "window-00000999").string()); }, {"does not exist"});

  writeFile(folder / "dem_state.bin", "dem state of window 101");
  expectRefused([&] { verifyCheckpoint(folder.string()); }, {"is damaged", "dem_state.bin", "CRC-32"});
  writeFile(folder / "dem_state.bin", "dem state of window 100");
  BOOST_CHECK_NO_THROW(verifyCheckpoint(folder.string()));

  fs::remove(folder / "fem_state.bin");
  expectRefused([&] { verifyCheckpoint(folder.string()); }, {"is incomplete", "fem_state.bin (fem side) is missing"});
  writeFile(folder / "fem_state.bin", "fem state of window 100");

  std::string older = manifest;
  older.replace(older.find("\"protocol_version\": 4"), 21, "\"protocol_version\": 3");
  writeFile(folder / "manifest.json", older);
  expectRefused([&] { verifyCheckpoint(folder.string()); }, {"protocol version 3", "this build speaks version 4"});

  writeFile(folder / "manifest.json", manifest.substr(0, manifest.size() / 2));
  expectRefused([&] { verifyCheckpoint(folder.string()); }, {"manifest.json is not a valid manifest"});

  fs::remove(folder / "manifest.json");
  expectRefused([&] { verifyCheckpoint(folder.string()); }, {"is incomplete", "no manifest.json"});
}

BOOST_AUTO_TEST_CASE(file_lists_and_restored_files) {
  Scratch scratch;
  const std::string staging = prepareCheckpoint(scratch.root.string(), checkpointName(5));
  writeFile(scratch.root / "monitor.csv", "time,u\n0,0\n");
  const CheckpointFile copied =
      copyIntoCheckpoint(staging, (scratch.root / "monitor.csv").string(), "fem_monitor.csv", "fem", "fem/monitor.csv");
  const std::vector<CheckpointFile> back = decodeCheckpointFiles(encodeCheckpointFiles({copied}));
  BOOST_TEST(back.size() == 1u);
  BOOST_TEST(back[0].name == "fem_monitor.csv");
  BOOST_TEST(back[0].restoreTo == "fem/monitor.csv");
  BOOST_TEST(back[0].crc32 == copied.crc32);
  BOOST_CHECK_THROW(decodeCheckpointFiles("fem\tonly three\tfields\n"), CheckpointError);

  CheckpointManifest manifest;
  manifest.name = checkpointName(5);
  manifest.window = 5;
  manifest.files = {copied};
  commitCheckpoint(scratch.root.string(), manifest);
  const fs::path work = scratch.root / "work";
  restoreCheckpointFiles((scratch.root / manifest.name).string(),
                         verifyCheckpoint((scratch.root / manifest.name).string()), "fem", work.string());
  BOOST_TEST(readFile(work / "fem" / "monitor.csv") == "time,u\n0,0\n");
  BOOST_TEST(!fs::exists(work / "fem" / "monitor.csv.restoring"));
}
