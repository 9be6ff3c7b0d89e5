// The path tracer's per-frame structs, shared by pathtrace.cl and the
// layout probe (pt_probe.cl). Mirrored by `DeviceCamera` and `DeviceFrame`
// in src/trace/render.rs; tests/render_reference.rs compares every size and
// offset.
#ifndef SOUPRAY_PT_TYPES_H
#define SOUPRAY_PT_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// PtFrame.flags
#define FRAME_NORMALS 1u
#define FRAME_UVS 2u
#define FRAME_CLAY 4u
#define FRAME_UVS1 8u   // the soup carries a second uv set
#define FRAME_COLORS 16u // the soup carries COLOR_0

// The camera. For a perspective camera `right` and `up` are scaled by the
// half extents of the image plane at distance 1; for an orthographic one by
// xmag and ymag.
typedef struct {
    float origin[4];
    float right[4];
    float up[4];
    float forward[4];
    uint ortho;
    float znear;
    uint pad[2];
} PtCamera;

// Per-frame constants. Next-event estimation at a path vertex samples every
// punctual light when `light_loop` is set, then one light drawn from the
// selection distribution (`select_cdf`, `select_count` entries in this
// order: the punctual lights unless looped, the emissive triangles as one
// entry when there are any, the environment when it is sampled).
// `emit_select_pmf` and `env_select_pmf` are the probabilities of choosing
// the emissive triangles and the environment (0 when not an entry), which
// MIS needs when a BSDF-sampled ray hits them.
typedef struct {
    uint seed_lo, seed_hi, frame_lo, frame_hi;
    uint width, height, max_depth, flags;
    uint light_count, emit_count, material_count, select_count;
    uint light_loop;
    float emit_select_pmf;
    float env_select_pmf;
    uint pad;
} PtFrame;

#endif
