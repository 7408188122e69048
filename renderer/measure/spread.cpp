#include "renderer/measure/spread.h"

#include <algorithm>

namespace raypack {

Spread spreadOf(std::vector<double> values) {
    Spread s;
    if (values.empty()) return s;
    std::sort(values.begin(), values.end());
    const size_t n = values.size();
    s.min = values.front();
    s.max = values.back();
    s.median = n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
    return s;
}

double upperMedian(std::vector<double> values) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

double steadyMedian(std::vector<double> values) {
    values.erase(values.begin(), values.begin() + values.size() / 2);
    return upperMedian(std::move(values));
}

}  // namespace raypack
