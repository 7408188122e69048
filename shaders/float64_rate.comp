#version 460
// The rate at which the device runs 64-bit float multiply-adds against 32-bit ones, for
// HitDistanceMath::Auto (renderer/vk/float64_rate.h): each invocation runs four independent chains
// of kIterations multiply-adds, in doubles or in floats (a specialization constant, one pipeline
// each), enough invocations to fill any GPU. The chains contract towards a fixed point (|m| < 1),
// so no value overflows or becomes subnormal; the sum is written so that none of it is dropped.
// The module uses doubles: it is created only on a device with shaderFloat64.
layout(local_size_x = 256, local_size_y = 1, local_size_z = 1) in;
layout(constant_id = 0) const bool kDouble = false;
layout(constant_id = 1) const uint kIterations = 1024;

layout(std430, binding = 0) writeonly buffer Result {
    float result[];
};

layout(push_constant) uniform Push {
    float multiplier;  // 0.999
    float addend;      // 0.001
}
push;

void main() {
    const uint id = gl_GlobalInvocationID.x;
    const float start = float(id & 255u) * (1.0f / 256.0f);
    float sum;
    if (kDouble) {
        const double m = double(push.multiplier), k = double(push.addend);
        double a = double(start), b = a + 0.25lf, c = a + 0.5lf, d = a + 0.75lf;
        for (uint i = 0u; i < kIterations; ++i) {
            a = a * m + k;
            b = b * m + k;
            c = c * m + k;
            d = d * m + k;
        }
        sum = float((a + b) + (c + d));
    } else {
        const float m = push.multiplier, k = push.addend;
        float a = start, b = a + 0.25f, c = a + 0.5f, d = a + 0.75f;
        for (uint i = 0u; i < kIterations; ++i) {
            a = a * m + k;
            b = b * m + k;
            c = c * m + k;
            d = d * m + k;
        }
        sum = (a + b) + (c + d);
    }
    result[id] = sum;
}
