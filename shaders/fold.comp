#version 460
#extension GL_GOOGLE_include_directive : require
// Folds the window's fixed-point sums (SlotDelta) into the frozen totals (SlotStats), clears
// them and recomputes the slot's weight coefficients; runs between passes (and once before
// the first, to set the coefficients of fresh or loaded statistics), one invocation per slot.
// The next window's scale is the slot's root mean square of y so far, which keeps y / scale
// near 1 and far from the fixed-point clamp. Mirror of src/learning/mod.rs `fold`.
#include "types.glsl"
#include "posterior.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) buffer Stats { SlotStats slot_stats[]; };
layout(std430, set = 0, binding = 1) buffer Delta { SlotDelta slot_delta[]; };
layout(std430, set = 0, binding = 2) readonly buffer Learn { LearnParams learn[]; };

// force: recompute every slot's coefficients (fresh or loaded statistics); otherwise slots
// whose window is empty are left alone (their coefficients cannot have changed). Most slots
// see no sample in a pass, so this skips most of the memory traffic of a fold.
layout(push_constant) uniform Push { uint slot_count; uint force; };

const float FIX_ONE = 16777216.0;
const float TWO_POW_32 = 4294967296.0;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= slot_count) return;
    SlotDelta d = slot_delta[i];
    if (force == 0u && d.n_zero + d.n_nonzero == 0u) return;
    SlotStats s = slot_stats[i];
    if (!(s.scale > 0.0)) s.scale = 1.0;
    if (d.n_zero + d.n_nonzero > 0u) {
        float sum = (float(d.sum_hi) * TWO_POW_32 + float(d.sum_lo)) * (s.scale / FIX_ONE);
        float sq = (float(d.sq_hi) * TWO_POW_32 + float(d.sq_lo)) * (s.scale * s.scale / FIX_ONE);
        s.n_zero += float(d.n_zero);
        s.n_nonzero += float(d.n_nonzero);
        s.sum += sum;
        s.sum_sq += sq;
        if (s.sum_sq > 0.0 && s.n_nonzero > 0.0) s.scale = sqrt(s.sum_sq / s.n_nonzero);
        slot_delta[i] = SlotDelta(0u, 0u, 0u, 0u, 0u, 0u, 0u, 0u);
    }
    vec3 c = weight_coefficients(s, learn[0]);
    s.coef_a = c.x;
    s.coef_b = c.y;
    s.coef_c = c.z;
    slot_stats[i] = s;
}
