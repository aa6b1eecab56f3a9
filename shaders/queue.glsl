// queue.glsl - the device-resident queue of rendering work packages (paper §7: 16x8-pixel
// blocks, one thread per pixel) and the per-block scheduling state of the §6 priorities.
// block_select.comp fills the queue, the rendering procedure (render_track.comp) runs one
// workgroup per queued block through an indirect dispatch, so the host never touches
// individual work items.
layout(set = 0, binding = 15, std430) buffer RenderQueue {
    uvec4 dispatch;    // xyz: indirect dispatch of the rendering procedure; w: blocks queued
    uvec4 totals;      // x: blocks queued since the host last read (and zeroed) it; y, z:
                       // scatter events (64 bits, count_events); w: samples measured
    uvec4 spread;      // PICVR_DISTANCE_AUTO (render.glsl, measure_spread): x, y the sum of
                       // squared deviations, z, w the sum of the means' variances (64 bits)
    uvec4 blocks[];    // [i].x: the i-th queued block; for block b: [b].y its credit and
                       // [b].z its priority (float bits; PRIORITY_FORCE: has unsampled pixels)
} render_queue;

#define BLOCK_W 16u
#define BLOCK_H 8u
#define PRIORITY_FORCE -1.0

uint blocks_per_row(uvec2 image) { return (image.x + BLOCK_W - 1u) / BLOCK_W; }
uint block_count(uvec2 image) { return blocks_per_row(image) * ((image.y + BLOCK_H - 1u) / BLOCK_H); }
uvec2 block_origin(uint b, uvec2 image) {
    uint bx = blocks_per_row(image);
    return uvec2((b % bx) * BLOCK_W, (b / bx) * BLOCK_H);
}
