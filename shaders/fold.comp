#version 460
#extension GL_GOOGLE_include_directive : require
// Folds the window's fixed-point sums (SlotDelta) into the frozen totals (SlotStats), clears
// them and recomputes the slot's weight coefficients; runs between passes over the slots the
// window touched (render.comp lists them), and once before the first pass over every slot,
// to set the coefficients of fresh or loaded statistics. One invocation per slot.
// The next window's scale is the slot's root mean square of y so far, which keeps y / scale
// near 1 and far from the fixed-point clamp. Mirror of src/learning/mod.rs `fold`.
#include "types.glsl"
#include "posterior.glsl"

layout(local_size_x = 64) in;

// The totals (SlotStats) and the window's sums (SlotDelta) are written here as storage
// buffers but read as uniform texel buffers of the same memory (two RGBA32UI texels a slot
// each; prior_texels one): lavapipe reads a storage buffer word by word and lane by lane but
// gathers a texel in one vector load, and a window's fold on city (128×96, 16 passes, 13.6k
// slots) took 0.68-0.70 ms this way against 1.27-1.52 ms; writing them as texels too
// (uimageBuffer) gained nothing more (0.67-0.74 ms; docs/results.md, sixteenth session).
layout(std430, set = 0, binding = 0) writeonly buffer Stats { SlotStats slot_stats[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Delta { SlotDelta slot_delta[]; };
layout(set = 0, binding = 4) uniform usamplerBuffer stat_texels;
layout(set = 0, binding = 5) uniform usamplerBuffer delta_texels;
// The window's touched slots as render.comp's mark_touched lists them: [0] the workgroup
// count of this dispatch (indirect), [1], [2] 1, [3] the count, then the slots, NO_SLOT
// after the last (the list has room for every slot, rounded up to whole workgroups).
layout(std430, set = 0, binding = 2) buffer Touched { uint touched_slots[]; };
// Each slot's borrowed pseudo-observations (n_zero, n_nonzero, Σy, Σy²; src/learning/pooling.rs,
// all 0 unless --pool-priors): added to the totals the posterior is computed from, never to
// the totals themselves.
layout(set = 0, binding = 3) uniform usamplerBuffer prior_texels;

// mode FOLD_TOUCHED (between passes, an indirect dispatch): the listed slots, and the list
// emptied for the next window; lavapipe runs the body for every invocation of a dispatch,
// even those that return at once, so visiting only the touched slots is what makes a fold
// cheap. FOLD_ALL: the slots from `first` on, coefficients recomputed (fresh or loaded
// statistics: from 0; slots appended by region growth or cut refinement: from the first new
// one, as the others' totals did not change); the list is left as it is.
// The learning's parameters come with the push constants (src/abi.rs FoldPush), not from a
// storage buffer: lavapipe loads a storage buffer word lane by lane even at an address every
// lane shares, and those loads were a fifth of a fold (every slot of city, 37k: 3.4 against
// 2.75 ms; docs/results.md, sixteenth session).
layout(push_constant) uniform FoldPush { uint slot_count; uint mode; uint first; LearnParams learn; };
#define FOLD_TOUCHED 0u
#define FOLD_ALL 1u
#define NO_SLOT 0xffffffffu

const float FIX_ONE = 16777216.0;
const float TWO_POW_32 = 4294967296.0;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (mode == FOLD_TOUCHED) {
        // The dispatch has read its size: the next window's list starts empty.
        if (i == 0u) {
            touched_slots[0] = 0u;
            touched_slots[3] = 0u;
        }
        uint e = 4u + i;
        i = touched_slots[e];
        if (i == NO_SLOT) return;
        touched_slots[e] = NO_SLOT;
    } else {
        i += first;
    }
    if (i >= slot_count) return;
    uvec4 da = texelFetch(delta_texels, int(2u * i));
    uvec4 db = texelFetch(delta_texels, int(2u * i + 1u));
    SlotDelta d = SlotDelta(da.x, da.y, da.z, da.w, db.x, db.y, db.z, db.w);
    vec4 sa = uintBitsToFloat(texelFetch(stat_texels, int(2u * i)));
    SlotStats s;
    s.n_zero = sa.x;
    s.n_nonzero = sa.y;
    s.sum = sa.z;
    s.sum_sq = sa.w;
    s.scale = uintBitsToFloat(texelFetch(stat_texels, int(2u * i + 1u)).x);
    if (!(s.scale > 0.0)) s.scale = 1.0;
    if (d.n_zero + d.n_nonzero > 0u) {
        float sum = (float(d.sum_hi) * TWO_POW_32 + float(d.sum_lo)) * (s.scale / FIX_ONE);
        float sq = (float(d.sq_hi) * TWO_POW_32 + float(d.sq_lo)) * (s.scale * s.scale / FIX_ONE);
        s.n_zero += float(d.n_zero);
        s.n_nonzero += float(d.n_nonzero);
        s.sum += sum;
        s.sum_sq += sq;
        if (s.sum_sq > 0.0 && s.n_nonzero > 0.0) s.scale = sqrt(s.sum_sq / s.n_nonzero);
    }
    // Cleared, and (FOLD_TOUCHED) off the list; FOLD_ALL keeps a listed slot listed, so the
    // list never holds a slot twice.
    uint listed = mode == FOLD_ALL ? d.touched : 0u;
    slot_delta[i] = SlotDelta(0u, 0u, 0u, 0u, 0u, 0u, listed, 0u);
    SlotStats post = s;
    vec4 pr = uintBitsToFloat(texelFetch(prior_texels, int(i)));
    post.n_zero += pr.x;
    post.n_nonzero += pr.y;
    post.sum += pr.z;
    post.sum_sq += pr.w;
    vec3 c = weight_coefficients(post, learn);
    s.coef_a = c.x;
    s.coef_b = c.y;
    s.coef_c = c.z;
    slot_stats[i] = s;
}
