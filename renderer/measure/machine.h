#pragma once
// What the machine is, as measurements name it: the CPU, its threads, the operating system, the
// date of a run.
#include <cstdint>
#include <string>

namespace raypack {

// CPU model from /proc/cpuinfo ("unknown CPU" when it cannot be read).
std::string cpuModel();
// Hardware threads (at least 1).
uint32_t cpuThreads();
// "WHAT, CPU model (N threads)": how the CPU tracers name the device they ran on.
std::string describeCpuDevice(const std::string& what);
// "Linux 6.1.0-13-amd64 x86_64" (uname), "unknown" when it cannot be read.
std::string operatingSystem();
// Now, as "2026-12-01T20:15:00Z".
std::string utcDate();

}  // namespace raypack
