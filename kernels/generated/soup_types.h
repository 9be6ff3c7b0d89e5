// Generated from the Rust definitions by soupray::device_struct
// (SOUPRAY_REGENERATE=1 cargo test --test device_structs). Do not edit:
// change the Rust definition named above each item.
//
// The soup evaluator's structs (src/soup/device.rs).
#ifndef SOUPRAY_GENERATED_SOUP_TYPES_H
#define SOUPRAY_GENERATED_SOUP_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// Marks an absent base index in [`SoupSegment`] (no skin, no morphs).
#define SOUP_NONE 4294967295u
// [`SoupSegment::flags`]: the primitive has NORMAL (else flat normals).
#define SEG_NORMALS 1u
// [`SoupSegment::flags`]: the primitive has TEXCOORD_0 (else 0, 0).
#define SEG_UVS 2u
// [`SoupSegment::flags`]: skinned by its instance's skin (else rigid).
#define SEG_SKINNED 4u
// The primitive has the soup's second uv set (else 0, 0).
#define SEG_UVS1 8u
// The primitive has COLOR_0 (else white).
#define SEG_COLORS 16u

// One primitive as placed by one mesh instance: where its static data and its
// deformed vertices live. Static data is stored once per primitive and shared
// by every instance of its mesh; deformed vertices are per instance. Uploaded
// once per scene.
// `SoupSegment` in src/soup/device.rs (48 bytes).
typedef struct {
    // first vertex of the primitive in the static arrays
    uint src_vertex;
    // first deformed vertex of this instance's copy
    uint dst_vertex;
    uint vertex_count;
    // index into the frame's SoupInstancePose array
    uint instance;
    // first influence record (INFLUENCE_SETS per vertex)
    uint influence_base;
    // first joint matrix (4 float4 columns each) of the skin
    uint joint_base;
    // first delta record (target_count per vertex)
    uint morph_base;
    // first morph weight of the instance in the frame's weights
    uint weight_base;
    uint target_count;
    // SEG_*
    uint flags;
    uint pad0;
    uint pad1;
} SoupSegment;

// The rigid transform of one mesh instance for one frame, prepared on the
// host by the same code as the CPU reference: the node's world matrix, the
// matrix that carries normals (cofactor * sign(det)) and its determinant.
// `SoupInstancePose` in src/soup/device.rs (128 bytes).
typedef struct {
    // columns
    float4 world_from_mesh[4];
    // columns; w unused
    float4 normal_matrix[3];
    float det;
    uint pad[3];
} SoupInstancePose;

#endif
