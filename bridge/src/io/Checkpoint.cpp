// Checkpoint folders: staging, CRC-32 of each file, manifest.json written last, atomic commit, pruning, verification.
#include "railcosim/Checkpoint.hpp"
#include "railcosim/Error.hpp"
#include "railcosim/StateStream.hpp"

#include "protocol/Message.hpp"

#include <boost/crc.hpp>
#include <boost/property_tree/json_parser.hpp>
#include <boost/property_tree/ptree.hpp>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

namespace railcosim {
namespace {

namespace fs = std::filesystem;

const char* const manifestFile = "manifest.json";
const char* const formatName = "railcosim-checkpoint 1";
const char* const partialSuffix = ".partial";

std::string environment(const char* name) {
  const char* value = std::getenv(name);
  return value ? value : "";
}

/// Flushes a file or folder to disk, so that the rename that commits a checkpoint never survives a crash
/// while the data it points to does not.
void syncPath(const std::string& path, bool directory) {
  const int fd = ::open(path.c_str(), directory ? (O_RDONLY | O_DIRECTORY) : O_RDONLY);
  if (fd < 0) throw Error("checkpoint: cannot open '" + path + "' to flush it (" + std::strerror(errno) + ")");
  const int status = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (status != 0) throw Error("checkpoint: flushing '" + path + "' failed (" + std::strerror(error) + ")");
}

std::string hex32(std::uint32_t value) {
  char text[9];
  std::snprintf(text, sizeof text, "%08x", value);
  return text;
}

std::uint32_t parseHex32(const std::string& text, const std::string& where) {
  char* end = nullptr;
  const unsigned long value = std::strtoul(text.c_str(), &end, 16);
  if (text.size() != 8 || end != text.c_str() + text.size())
    throw CheckpointError(where + ": CRC-32 '" + text + "' is not 8 hex digits");
  return static_cast<std::uint32_t>(value);
}

std::string jsonText(const std::string& value) {
  std::ostringstream out;
  out << '"';
  for (unsigned char c : value) {
    if (c == '"' || c == '\\') {
      out << '\\' << c;
    } else if (c < 0x20) {
      out << "\\u" << std::hex << std::setw(4) << std::setfill('0') << static_cast<int>(c) << std::dec;
    } else {
      out << c;
    }
  }
  out << '"';
  return out.str();
}

/// "window-00000800" -> 800; -1 for any other name (staging folders included).
long long windowOfName(const std::string& name) {
  const std::string prefix = "window-";
  if (name.size() != prefix.size() + 8 || name.compare(0, prefix.size(), prefix) != 0) return -1;
  long long window = 0;
  for (std::size_t i = prefix.size(); i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9') return -1;
    window = 10 * window + (name[i] - '0');
  }
  return window;
}

/// Complete checkpoints under root, oldest first.
std::vector<std::pair<long long, fs::path>> completeCheckpoints(const std::string& root) {
  std::vector<std::pair<long long, fs::path>> found;
  std::error_code error;
  if (!fs::is_directory(root, error)) return found;
  for (const auto& entry : fs::directory_iterator(root, error)) {
    const long long window = windowOfName(entry.path().filename().string());
    if (window >= 0 && entry.is_directory() && fs::exists(entry.path() / manifestFile))
      found.emplace_back(window, entry.path());
  }
  std::sort(found.begin(), found.end());
  return found;
}

} // namespace

CheckpointSettings CheckpointSettings::fromEnvironment() {
  CheckpointSettings settings;
  settings.folder = environment("RAILCOSIM_CHECKPOINT_DIR");
  settings.resumeFrom = environment("RAILCOSIM_RESUME");
  settings.run = environment("RAILCOSIM_CHECKPOINT_RUN");
  return settings;
}

std::string checkpointName(std::uint64_t window) {
  char text[32];
  std::snprintf(text, sizeof text, "window-%08llu", static_cast<unsigned long long>(window));
  return text;
}

std::string stagingFolder(const std::string& root, const std::string& name) {
  return (fs::path(root) / (name + partialSuffix)).string();
}

CheckpointFile describeCheckpointFile(const std::string& folder, const std::string& name, const std::string& side,
                                      const std::string& restoreTo) {
  const std::string path = (fs::path(folder) / name).string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("checkpoint: cannot read '" + path + "' (" + std::strerror(errno) + ")");
  boost::crc_32_type crc;
  CheckpointFile file;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const std::streamsize got = in.gcount();
    crc.process_bytes(buffer.data(), static_cast<std::size_t>(got));
    file.bytes += static_cast<std::uint64_t>(got);
  }
  if (in.bad()) throw Error("checkpoint: reading '" + path + "' failed");
  syncPath(path, false);
  file.side = side;
  file.name = name;
  file.restoreTo = restoreTo;
  file.crc32 = crc.checksum();
  return file;
}

CheckpointFile copyIntoCheckpoint(const std::string& staging, const std::string& source, const std::string& name,
                                  const std::string& side, const std::string& restoreTo) {
  std::error_code error;
  fs::copy_file(source, fs::path(staging) / name, fs::copy_options::overwrite_existing, error);
  if (error) throw Error("checkpoint: cannot copy '" + source + "' into " + staging + " (" + error.message() + ")");
  return describeCheckpointFile(staging, name, side, restoreTo);
}

std::string encodeCheckpointFiles(const std::vector<CheckpointFile>& files) {
  std::ostringstream text;
  for (const CheckpointFile& file : files) {
    for (const std::string* field : {&file.side, &file.name, &file.restoreTo}) {
      if (field->find_first_of("\t\n") != std::string::npos)
        throw Error("checkpoint: file name '" + *field + "' contains a tab or a line break");
    }
    text << file.side << '\t' << file.name << '\t' << file.restoreTo << '\t' << file.bytes << '\t' << hex32(file.crc32)
         << '\n';
  }
  return text.str();
}

std::vector<CheckpointFile> decodeCheckpointFiles(const std::string& text) {
  std::vector<CheckpointFile> files;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    std::vector<std::string> fields;
    std::size_t start = 0;
    for (std::size_t tab; (tab = line.find('\t', start)) != std::string::npos; start = tab + 1)
      fields.push_back(line.substr(start, tab - start));
    fields.push_back(line.substr(start));
    if (fields.size() != 5 || fields[1].empty())
      throw CheckpointError("checkpoint file list: line '" + line + "' is not 'side name restoreTo bytes crc32'");
    CheckpointFile file;
    file.side = fields[0];
    file.name = fields[1];
    file.restoreTo = fields[2];
    file.bytes = std::strtoull(fields[3].c_str(), nullptr, 10);
    file.crc32 = parseHex32(fields[4], "checkpoint file list");
    files.push_back(file);
  }
  return files;
}

std::string prepareCheckpoint(const std::string& root, const std::string& name) {
  const std::string staging = stagingFolder(root, name);
  std::error_code error;
  fs::remove_all(staging, error);
  fs::create_directories(staging, error);
  if (error) throw Error("checkpoint: cannot create '" + staging + "' (" + error.message() + ")");
  return staging;
}

void commitCheckpoint(const std::string& root, const CheckpointManifest& manifest, int keep) {
  const std::string staging = stagingFolder(root, manifest.name);
  const std::string final = (fs::path(root) / manifest.name).string();
  std::map<std::string, int> seen;
  for (const CheckpointFile& file : manifest.files) {
    if (++seen[file.name] > 1) throw Error("checkpoint " + final + ": two files are named '" + file.name + "'");
  }
  std::ostringstream json;
  json << "{\n  \"format\": " << jsonText(formatName) << ",\n  \"name\": " << jsonText(manifest.name)
       << ",\n  \"protocol_version\": " << protocol::protocolVersion << ",\n  \"window\": " << manifest.window
       << ",\n  \"time\": " << std::setprecision(17) << manifest.time
       << ",\n  \"scheme\": " << jsonText(manifest.scheme) << ",\n  \"run\": " << jsonText(manifest.run)
       << ",\n  \"files\": [";
  for (std::size_t i = 0; i < manifest.files.size(); ++i) {
    const CheckpointFile& file = manifest.files[i];
    json << (i ? ",\n" : "\n") << "    {\"side\": " << jsonText(file.side) << ", \"name\": " << jsonText(file.name)
         << ", \"restore_to\": " << jsonText(file.restoreTo) << ", \"bytes\": " << file.bytes
         << ", \"crc32\": " << jsonText(hex32(file.crc32)) << "}";
  }
  json << "\n  ]\n}\n";
  const std::string manifestPath = (fs::path(staging) / manifestFile).string();
  {
    std::ofstream out(manifestPath + ".tmp", std::ios::trunc);
    out << json.str();
    out.close();
    if (!out) throw Error("checkpoint: writing '" + manifestPath + ".tmp' failed (disk full?)");
  }
  syncPath(manifestPath + ".tmp", false);
  std::error_code error;
  fs::rename(manifestPath + ".tmp", manifestPath, error);
  if (error) throw Error("checkpoint: cannot rename the manifest in " + staging + " (" + error.message() + ")");
  syncPath(staging, true);
  // A complete checkpoint of the same name (a run resumed from an older one passes the same window again) gives way.
  fs::remove_all(final, error);
  fs::rename(staging, final, error);
  if (error) throw Error("checkpoint: cannot rename " + staging + " to " + final + " (" + error.message() + ")");
  syncPath(root, true);
  // Prune: the newest `keep` complete checkpoints stay; interrupted saves are gone for good.
  const auto complete = completeCheckpoints(root);
  for (std::size_t i = 0; i + static_cast<std::size_t>(std::max(keep, 1)) < complete.size(); ++i)
    fs::remove_all(complete[i].second, error);
  for (const auto& entry : fs::directory_iterator(root, error)) {
    const std::string name = entry.path().filename().string();
    if (name.size() > std::strlen(partialSuffix) &&
        name.compare(name.size() - std::strlen(partialSuffix), std::string::npos, partialSuffix) == 0 &&
        windowOfName(name.substr(0, name.size() - std::strlen(partialSuffix))) >= 0)
      fs::remove_all(entry.path(), error);
  }
}

CheckpointManifest verifyCheckpoint(const std::string& folder) {
  std::error_code error;
  if (!fs::is_directory(folder, error)) throw CheckpointError("checkpoint " + folder + " does not exist");
  const std::string manifestPath = (fs::path(folder) / manifestFile).string();
  if (!fs::exists(manifestPath, error))
    throw CheckpointError(
        "checkpoint " + folder +
        " is incomplete: it has no manifest.json (its save was interrupted); resume from a complete one");
  namespace pt = boost::property_tree;
  pt::ptree tree;
  CheckpointManifest manifest;
  try {
    pt::read_json(manifestPath, tree);
    if (tree.get<std::string>("format") != formatName)
      throw CheckpointError("checkpoint " + folder + ": manifest.json has format '" + tree.get<std::string>("format") +
                            "', this release reads '" + formatName + "'");
    manifest.name = tree.get<std::string>("name");
    manifest.protocolVersion = tree.get<std::uint16_t>("protocol_version");
    manifest.window = tree.get<std::uint64_t>("window");
    manifest.time = tree.get<double>("time");
    manifest.scheme = tree.get<std::string>("scheme");
    manifest.run = tree.get<std::string>("run");
    for (const auto& entry : tree.get_child("files")) {
      CheckpointFile file;
      file.side = entry.second.get<std::string>("side");
      file.name = entry.second.get<std::string>("name");
      file.restoreTo = entry.second.get<std::string>("restore_to");
      file.bytes = entry.second.get<std::uint64_t>("bytes");
      file.crc32 = parseHex32(entry.second.get<std::string>("crc32"), "checkpoint " + folder);
      manifest.files.push_back(file);
    }
  } catch (const pt::ptree_error& problem) {
    throw CheckpointError("checkpoint " + folder + ": manifest.json is not a valid manifest (" + problem.what() + ")");
  }
  if (manifest.protocolVersion != protocol::protocolVersion)
    throw CheckpointError("checkpoint " + folder + " was written with bridge protocol version " +
                          std::to_string(manifest.protocolVersion) + ", this build speaks version " +
                          std::to_string(protocol::protocolVersion) + "; resume it with the release that wrote it");
  for (const CheckpointFile& file : manifest.files) {
    const fs::path path = fs::path(folder) / file.name;
    if (!fs::exists(path, error))
      throw CheckpointError("checkpoint " + folder + " is incomplete: " + file.name + " (" + file.side +
                            " side) is missing");
    const CheckpointFile found = describeCheckpointFile(folder, file.name, file.side);
    if (found.bytes != file.bytes || found.crc32 != file.crc32)
      throw CheckpointError("checkpoint " + folder + " is damaged: " + file.name + " has " +
                            std::to_string(found.bytes) + " bytes, CRC-32 " + hex32(found.crc32) +
                            ", the manifest says " + std::to_string(file.bytes) + " bytes, CRC-32 " +
                            hex32(file.crc32));
  }
  return manifest;
}

std::string latestCheckpoint(const std::string& root) {
  const auto complete = completeCheckpoints(root);
  return complete.empty() ? std::string() : complete.back().second.string();
}

void restoreCheckpointFiles(const std::string& folder, const CheckpointManifest& manifest, const std::string& side,
                            const std::string& workFolder) {
  for (const CheckpointFile& file : manifest.files) {
    if (file.side != side || file.restoreTo.empty()) continue;
    const fs::path target = fs::path(workFolder) / file.restoreTo;
    const fs::path temporary = target.string() + ".restoring";
    std::error_code error;
    fs::create_directories(target.parent_path(), error);
    fs::copy_file(fs::path(folder) / file.name, temporary, fs::copy_options::overwrite_existing, error);
    if (!error) fs::rename(temporary, target, error);
    if (error)
      throw Error("checkpoint " + folder + ": cannot put " + file.name + " back as " + target.string() + " (" +
                  error.message() + ")");
  }
}

std::string relativeToWorkFolder(const std::string& path, const std::string& caller) {
  namespace fs = std::filesystem;
  const fs::path relative = fs::absolute(path).lexically_normal().lexically_relative(fs::current_path());
  if (relative.empty() || *relative.begin() == "..")
    throw std::invalid_argument(caller + ": " + path + " lies outside the working folder " +
                                fs::current_path().string() + "; only the run's own outputs can be checkpointed");
  return relative.string();
}

void refuseResume(const std::string& folder, const std::string& what) {
  throw CheckpointError("checkpoint " + folder + ": " + what + "; resume with the case and parameters of the interrupted run");
}

void checkSavedCoupling(const std::string& folder, const SavedCoupling& saved, double femDt, std::int64_t subcycles,
                        const std::vector<double>& triangles, std::uint64_t manifestWindow) {
  if (saved.femDt != femDt) refuseResume(folder, "the FEM side's window length differs from the saved one");
  if (saved.subcycles != subcycles) refuseResume(folder, "the DEM steps per window differ from the saved ones");
  if (saved.triangles != triangles) refuseResume(folder, "the FEM side's interface triangles differ from the saved ones");
  if (static_cast<std::uint64_t>(saved.window) != manifestWindow)
    refuseResume(folder, "the DEM state is of window " + std::to_string(saved.window) + ", the manifest's of window " +
                             std::to_string(manifestWindow));
}

std::string completeDemCheckpoint(const std::string& root, CheckpointManifest manifest, const DemCheckpointContent& content,
                                  const std::vector<CheckpointFile>& femFiles) {
  const std::string staging = stagingFolder(root, manifest.name);
  std::vector<CheckpointFile> written;
  {
    std::ofstream out(staging + "/" + content.stateFile, std::ios::binary | std::ios::trunc);
    StateWriter state(out);
    for (const auto& [name, bytes] : content.sections) {
      state.section(name);
      state.bytes(bytes);
    }
    state.section("end");
    out.close();
    if (!out) throw Error("writing " + staging + "/" + content.stateFile + " failed (disk full?)");
  }
  written.push_back(describeCheckpointFile(staging, content.stateFile, "dem"));
  for (const std::string& path : content.files)
    written.push_back(copyIntoCheckpoint(staging, path, std::filesystem::path(path).filename().string(), "dem",
                                         relativeToWorkFolder(path, content.caller)));
  manifest.files = written;
  manifest.files.insert(manifest.files.end(), femFiles.begin(), femFiles.end());
  commitCheckpoint(root, manifest);
  return (std::filesystem::path(root) / manifest.name).string();
}

} // namespace railcosim
