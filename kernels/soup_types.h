// Structs shared by the host and the soup kernels (soup_eval.cl). Each one
// is mirrored once in src/soup/device.rs; the test `soup_layout_matches_device`
// runs soup_layout_probe.cl and compares every size and offset below with the
// Rust side.
#ifndef SOUPRAY_SOUP_TYPES_H
#define SOUPRAY_SOUP_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// Marks an absent base index (no skin, no morph targets).
#define SOUP_NONE 0xFFFFFFFFu

// SoupSegment.flags
#define SEG_NORMALS 1u  // the primitive has NORMAL (else flat normals)
#define SEG_UVS     2u  // the primitive has TEXCOORD_0 (else 0, 0)
#define SEG_SKINNED 4u  // skinned by its instance's skin (else rigid)
#define SEG_UVS1    8u  // the primitive has the soup's second uv set (else 0, 0)
#define SEG_COLORS 16u  // the primitive has COLOR_0 (else white)

// One primitive as placed by one mesh instance: where its static data and its
// deformed vertices live. Static data is stored once per primitive and shared
// by every instance of its mesh; deformed vertices are per instance. Uploaded
// once per scene.
typedef struct {
    uint src_vertex;     // first vertex of the primitive in the static arrays
    uint dst_vertex;     // first deformed vertex of this instance's copy
    uint vertex_count;
    uint instance;       // index into the frame's SoupInstancePose array
    uint influence_base; // first influence record (INFLUENCE_SETS per vertex)
    uint joint_base;     // first joint matrix (4 float4 columns each) of the skin
    uint morph_base;     // first delta record (target_count per vertex)
    uint weight_base;    // first morph weight of the instance in the frame's weights
    uint target_count;
    uint flags;          // SEG_*
    uint pad0;
    uint pad1;
} SoupSegment;

// The rigid transform of one mesh instance for one frame, prepared on the
// host by the same code as the CPU reference: the node's world matrix, the
// matrix that carries normals (cofactor * sign(det)) and its determinant.
typedef struct {
    float4 world_from_mesh[4]; // columns
    float4 normal_matrix[3];   // columns; w unused
    float det;
    uint pad0;
    uint pad1;
    uint pad2;
} SoupInstancePose;

#endif
