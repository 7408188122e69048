#pragma once
// Medians and spreads of repeated measurements, and the host clock they are taken with: one
// definition for every tracer and program that times something (raypack-cli, the viewer, the
// driver's ray tracing and Embree peers).
#include <chrono>
#include <vector>

namespace raypack {

// Median, minimum and maximum of repeated measurements.
struct Spread {
    double median = 0.0;
    double min = 0.0;
    double max = 0.0;
};
// Median of an even count is the mean of the two middle values. Empty input gives zeros.
Spread spreadOf(std::vector<double> values);

// The value at index n/2 of the sorted values (the upper of the two middle ones for an even
// count), 0 when empty: always a value that was measured, as the viewer reports its frame rates
// and latencies. The bench and raypack-cli report spreadOf's median.
double upperMedian(std::vector<double> values);
// upperMedian of the second half of `values`, in the order they were measured: the steady state
// after start-up (the first frames pay for pipeline compilation and the clocks rising).
double steadyMedian(std::vector<double> values);

using SteadyClock = std::chrono::steady_clock;
// Seconds from `start` to now on the steady clock (host wall time, never adjusted).
inline double secondsSince(SteadyClock::time_point start) {
    return std::chrono::duration<double>(SteadyClock::now() - start).count();
}

}  // namespace raypack
