#pragma once
// Errors in tiers (see ../shared/STYLE.md):
//  - what a user can cause (bad file, no device, out of memory) is a raypack::Error, thrown by the
//    library and caught at the program's boundary, where the CLI prints it and exits non-zero and the
//    viewer shows it and keeps running;
//  - a broken invariant is RAYPACK_CHECK, always on, printing file, line and expression.
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace raypack {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

[[noreturn]] inline void checkFailed(const char* expr, const char* file, int line, const char* msg) {
    std::fprintf(stderr, "raypack: internal check failed: %s (%s:%d)%s%s\n", expr, file, line, msg ? ": " : "",
                 msg ? msg : "");
    std::abort();
}

}  // namespace raypack

#define RAYPACK_CHECK(expr) ((expr) ? (void)0 : ::raypack::checkFailed(#expr, __FILE__, __LINE__, nullptr))
#define RAYPACK_CHECK_MSG(expr, msg) ((expr) ? (void)0 : ::raypack::checkFailed(#expr, __FILE__, __LINE__, (msg)))
