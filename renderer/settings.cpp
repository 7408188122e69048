#include "renderer/settings.h"

namespace raypack {

// The same names renderer/settings_json.cpp writes, so what the CLI prints can be typed back.
const char* toString(KernelKind kind) {
    switch (kind) {
    case KernelKind::Packet: return "packet";
    case KernelKind::Single: return "single";
    }
    return "unknown";
}

const char* toString(ViewMode mode) {
    switch (mode) {
    case ViewMode::Shaded: return "shaded";
    case ViewMode::HeatTraversal: return "nodes";
    case ViewMode::HeatIntersections: return "tests";
    }
    return "unknown";
}

}  // namespace raypack
