#version 450
// block_select.comp - fills the rendering queue for one dispatch of the rendering
// procedure (one workgroup, 256 threads), `want` blocks on average:
//  - priorities off: the next `want` blocks of a fixed round-robin order, from
//    `cursor`: block (k * stride) mod B for k = cursor, cursor + 1, ... (the host passes
//    base = (cursor * stride) mod B; all products here stay below 2^32).  The stride is
//    coprime with B and near B / golden ratio, so any run of consecutive k is spread
//    over the whole image: every round's blocks cost about the image's mean per block,
//    which keeps the host's cost-per-block estimate (and so the step budget) right.
//  - priorities on (§6): block b earns the credit
//        want * ((1 - f) p_b / sum(p) + f / B)
//    (p_b from block_priority.comp, f = STARVATION_FLOOR) and is queued once its credit
//    reaches 1.  So blocks are rendered in proportion to their expected error reduction,
//    and every block keeps at least the fraction f of the uniform rate: none starves.
//    A block appears at most once per dispatch (its pixels' accumulation is not
//    atomic), so credit beyond one sample per dispatch is dropped.
#extension GL_GOOGLE_include_directive : require
layout(local_size_x = 256) in;

#include "queue.glsl"

// stride: the round-robin stride, 0 for priorities; base: with priorities, the block
// where the scan starts
layout(push_constant) uniform Push { uint want; uint block_count; uint base; uint stride; } pc;

#define STARVATION_FLOOR 0.1
#define MAX_QUEUE 65535u          // the smallest maxComputeWorkGroupCount[0] Vulkan allows

shared float s_sum[256];
shared uint s_best[256];
shared uint s_count;

void main() {
    uint lid = gl_LocalInvocationID.x;
    uint B = pc.block_count;
    uint cap = min(B, MAX_QUEUE);
    uint want = min(pc.want, cap);
    if (pc.stride != 0u) {
        uint b = (pc.base + (lid * pc.stride) % B) % B, step = (256u * pc.stride) % B;
        for (uint i = lid; i < want; i += 256u) {
            render_queue.blocks[i].x = b;
            b = (b + step) % B;
        }
        if (lid == 0u) {
            render_queue.dispatch = uvec4(want, 1u, 1u, want);
            render_queue.totals.x += want;
        }
        return;
    }
    float part = 0.0;
    for (uint b = lid; b < B; b += 256u) part += max(uintBitsToFloat(render_queue.blocks[b].z), 0.0);
    s_sum[lid] = part;
    if (lid == 0u) s_count = 0u;
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        barrier();
        if (lid < stride) s_sum[lid] += s_sum[lid + stride];
    }
    barrier();
    float total = s_sum[0];
    barrier();                                       // s_sum is reused below
    // Rule: when no block has a positive priority (all converged, or all black) the
    // shares are uniform.
    float uniform_share = 1.0 / float(B);
    float best_credit = -1.0;
    uint best = 0u;
    // At most `want` blocks, so the round's cost is what the host planned; blocks whose
    // credit reached 1 but found no slot keep it and go first next time, and the scan
    // starts at a rotating block (base) so that no part of the image always loses.
    cap = min(cap, max(want, 1u));
    for (uint j = lid; j < B; j += 256u) {
        uint b = (j + pc.base) % B;
        float p = uintBitsToFloat(render_queue.blocks[b].z);
        float rel = total > 0.0 ? max(p, 0.0) / total : uniform_share;
        float credit = uintBitsToFloat(render_queue.blocks[b].y)
                     + float(want) * ((1.0 - STARVATION_FLOOR) * rel + STARVATION_FLOOR * uniform_share);
        if (p == PRIORITY_FORCE) credit = max(credit, 1.0);
        if (credit >= 1.0) {
            uint slot = atomicAdd(s_count, 1u);
            if (slot < cap) { render_queue.blocks[slot].x = b; credit -= 1.0; }
        }
        render_queue.blocks[b].y = floatBitsToUint(min(credit, 1.0));
        if (credit > best_credit) { best_credit = credit; best = b; }
    }
    // Rule: a dispatch renders at least one block (a round of a tiny budget must still
    // make progress): if no credit reached 1, the block closest to it goes.
    s_sum[lid] = best_credit;
    s_best[lid] = best;
    for (uint stride = 128u; stride > 0u; stride >>= 1u) {
        barrier();
        if (lid < stride && s_sum[lid + stride] > s_sum[lid]) {
            s_sum[lid] = s_sum[lid + stride];
            s_best[lid] = s_best[lid + stride];
        }
    }
    barrier();
    if (lid == 0u) {
        if (s_count == 0u) {
            render_queue.blocks[0].x = s_best[0];
            render_queue.blocks[s_best[0]].y = floatBitsToUint(max(s_sum[0] - 1.0, 0.0));
            s_count = 1u;
        }
        uint n = min(s_count, cap);
        render_queue.dispatch = uvec4(n, 1u, 1u, n);
        render_queue.totals.x += n;
    }
}
