// Child processes for the integration tests: start a stand-in participant, capture its output, wait, signal.
#pragma once

#include <boost/test/unit_test.hpp>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace railcosim::test {

using Clock = std::chrono::steady_clock;

inline std::string uniqueName() {
  static std::atomic<int> counter{0};
  return "railcosim-it-" + std::to_string(getpid()) + "-" + std::to_string(counter++);
}

inline void sleepSeconds(double seconds) { std::this_thread::sleep_for(std::chrono::duration<double>(seconds)); }

inline bool contains(const std::string& text, const std::string& fragment) {
  const bool found = text.find(fragment) != std::string::npos;
  if (!found) BOOST_TEST_MESSAGE("'" << fragment << "' not in: " << text);
  return found;
}

/// A child process with stdout and stderr captured in files; killed (SIGKILL) if still running at the end.
class Process {
public:
  Process(const std::string& program, std::vector<std::string> arguments) {
    const std::string base = "/tmp/" + uniqueName();
    outPath_ = base + ".out";
    errPath_ = base + ".err";
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, outPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&actions, 2, errPath_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    arguments.insert(arguments.begin(), program);
    std::vector<char*> argv;
    for (auto& argument : arguments) argv.push_back(argument.data());
    argv.push_back(nullptr);
    const int status = posix_spawn(&pid_, program.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    BOOST_REQUIRE_MESSAGE(status == 0, "cannot start " << program);
  }
  ~Process() {
    if (running()) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    unlink(outPath_.c_str());
    unlink(errPath_.c_str());
  }
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  pid_t pid() const { return pid_; }
  bool running() {
    if (!finished_) poll();
    return !finished_;
  }
  void signal(int number) { kill(pid_, number); }
  /// Waits at most `seconds`; returns the exit code (128 + signal if killed), or -1 if still running
  /// (then fails the test).
  int wait(double seconds) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
    while (!finished_) {
      poll();
      if (finished_) break;
      if (Clock::now() > deadline) {
        BOOST_ERROR("process did not end within " << seconds << " s; stderr: " << errors());
        return -1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return exitCode_;
  }
  std::string output() const { return read(outPath_); }
  std::string errors() const { return read(errPath_); }
  /// Waits at most `seconds` for `fragment` on stderr; returns the rest of that line ("" if it never came).
  std::string awaitError(const std::string& fragment, double seconds) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
    while (Clock::now() < deadline) {
      const std::string text = errors();
      const std::size_t at = text.find(fragment);
      if (at != std::string::npos && text.find('\n', at) != std::string::npos) {
        const std::size_t from = at + fragment.size();
        return text.substr(from, text.find('\n', at) - from);
      }
      if (!running()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    BOOST_ERROR("'" << fragment << "' did not appear on stderr within " << seconds << " s: " << errors());
    return "";
  }

private:
  void poll() {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      finished_ = true;
      exitCode_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
  }
  static std::string read(const std::string& path) {
    std::ifstream file(path);
    std::stringstream text;
    text << file.rdbuf();
    return text.str();
  }
  pid_t pid_ = 0;
  bool finished_ = false;
  int exitCode_ = -1;
  std::string outPath_, errPath_;
};

/// A loopback port held (bound with SO_REUSEADDR, not listening) until released: the kernel hands it to
/// nobody else meanwhile, while ZeroMQ's listener (which also sets SO_REUSEADDR) can still bind it. Lets a
/// connecting participant start before the binding one without two tests ever sharing a port.
class ReservedPort {
public:
  ReservedPort() {
    socket_ = ::socket(AF_INET, SOCK_STREAM, 0);
    const int on = 1;
    setsockopt(socket_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof(on));
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    BOOST_REQUIRE(::bind(socket_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0);
    socklen_t length = sizeof(address);
    getsockname(socket_, reinterpret_cast<sockaddr*>(&address), &length);
    port_ = ntohs(address.sin_port);
  }
  ~ReservedPort() { release(); }
  ReservedPort(const ReservedPort&) = delete;
  ReservedPort& operator=(const ReservedPort&) = delete;
  std::string endpoint() const { return "tcp://127.0.0.1:" + std::to_string(port_); }
  void release() {
    if (socket_ >= 0) ::close(socket_);
    socket_ = -1;
  }

private:
  int socket_ = -1;
  int port_ = 0;
};

/// The FEM participant's bound endpoint, from its "listening on" line (needs RAILCOSIM_LOG=info).
inline std::string announcedEndpoint(Process& fem, double seconds = 10.0) {
  return fem.awaitError(": listening on ", seconds);
}

} // namespace railcosim::test
