// Plain ZeroMQ ping-pong over the same transport the bridge uses, as the reference for its cost.
#include "com/RawTransfer.hpp"
#include "railcosim/Error.hpp"

#include <zmq.h>

#include <chrono>
#include <unistd.h>
#include <exception>
#include <thread>
#include <vector>

namespace railcosim::com {
namespace {

struct Endpoint {
  void* context = nullptr;
  void* socket = nullptr;
  Endpoint(const std::string& endpoint, bool bind) {
    context = zmq_ctx_new();
    socket = zmq_socket(context, ZMQ_PAIR);
    // Long enough that the echo side's last reply is flushed before its socket closes.
    const int linger = 2000;
    const int timeout = 10000; // ms; a lost message fails the measurement instead of hanging it
    zmq_setsockopt(socket, ZMQ_LINGER, &linger, sizeof(linger));
    zmq_setsockopt(socket, ZMQ_RCVTIMEO, &timeout, sizeof(timeout));
    zmq_setsockopt(socket, ZMQ_SNDTIMEO, &timeout, sizeof(timeout));
    const int status = bind ? zmq_bind(socket, endpoint.c_str()) : zmq_connect(socket, endpoint.c_str());
    if (status != 0) {
      const std::string reason = zmq_strerror(zmq_errno());
      close();
      throw Error("raw transfer baseline: cannot " + std::string(bind ? "bind " : "connect ") + endpoint + ": " +
                  reason);
    }
  }
  ~Endpoint() { close(); }
  void close() {
    if (socket) zmq_close(socket);
    if (context) zmq_ctx_term(context);
    socket = context = nullptr;
  }
  void send(const std::vector<char>& buffer) {
    if (zmq_send(socket, buffer.data(), buffer.size(), 0) < 0) throw Error("raw transfer baseline: send timed out");
  }
  void receive() {
    zmq_msg_t message;
    zmq_msg_init(&message);
    const int status = zmq_msg_recv(&message, socket, 0);
    zmq_msg_close(&message);
    if (status < 0) throw Error("raw transfer baseline: receive timed out");
  }
};

} // namespace

RawRoundTrip measureRawRoundTrip(const std::string& endpoint, std::size_t forwardBytes, std::size_t backwardBytes,
                                 int roundTrips, int warmup) {
  const std::vector<char> forward(forwardBytes, 'f');
  const std::vector<char> backward(backwardBytes, 'b');
  Endpoint binder(endpoint, true);
  std::exception_ptr echoError;
  std::thread echo([&] {
    try {
      Endpoint connector(endpoint, false);
      for (int i = 0; i < warmup + roundTrips; ++i) {
        connector.receive();
        connector.send(backward);
      }
    } catch (...) {
      echoError = std::current_exception();
    }
  });
  RawRoundTrip result;
  std::exception_ptr mainError;
  try {
    for (int i = 0; i < warmup; ++i) {
      binder.send(forward);
      binder.receive();
    }
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < roundTrips; ++i) {
      binder.send(forward);
      binder.receive();
    }
    result.secondsPerRoundTrip =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / roundTrips;
    result.roundTrips = roundTrips;
  } catch (...) {
    mainError = std::current_exception();
  }
  echo.join();
  binder.close();
  const std::string prefix = "ipc://";
  if (endpoint.rfind(prefix, 0) == 0) ::unlink(endpoint.substr(prefix.size()).c_str()); // libzmq leaves it
  if (mainError) std::rethrow_exception(mainError);
  if (echoError) std::rethrow_exception(echoError);
  return result;
}

} // namespace railcosim::com
