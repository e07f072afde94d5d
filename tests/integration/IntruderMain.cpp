// railcosim_intruder ENDPOINT: makes every stray and hostile connection of the tests against a live endpoint.
#include "Intrusions.hpp"

#include <chrono>
#include <exception>
#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: railcosim_intruder ENDPOINT   (ipc:///path or tcp://127.0.0.1:PORT)\n";
    return 2;
  }
  try {
    for (const auto& attack : railcosim::test::intrusion::all()) {
      const auto start = std::chrono::steady_clock::now();
      const std::size_t taken = attack.run(argv[1]);
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::cout << "intrusion '" << attack.name << "': target took " << taken << " bytes, " << seconds << " s"
                << std::endl;
    }
  } catch (const std::exception& error) {
    std::cerr << "railcosim_intruder: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
