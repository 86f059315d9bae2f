// mesh.wgsl: draws a reference mesh with the camera and the shading of the ORI shader, so
// that the two can be compared pixel for pixel and composited in one depth buffer.
//
// Base colour = material factor x base-colour texture (sRGB, decoded by the sampler) x
// vertex colour, in linear light (the convention of `ori-mesh`); alpha-tested (MASK)
// materials discard below their cutoff. Shading is the evaluator's comparison shading
// (`ori_eval::Shading`): albedo x (0.3 + 0.7 max(0, n . l)), the light fixed to the view.
// The shading normal is turned to the side of the surface the viewer sees, as the baker
// turns it (double-sided materials draw both windings; single-sided ones are drawn by a
// pipeline that culls back faces).

struct Globals {
    world_to_clip: mat4x4<f32>,
    light: vec4<f32>,
    // Orthographic (w = 0): xyz is the view direction towards the viewer.
    // Perspective (w = 1): xyz is the eye.
    view: vec4<f32>,
    // How clip depth follows distance (ori.wgsl's option 5; unused here).
    depth: vec4<f32>,
};

struct Material {
    factor: vec4<f32>,
    // x: alpha cutoff, y: 1 when alpha-tested (MASK), z: 1 when a texture is bound.
    alpha: vec4<f32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;

@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var base_color: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;

struct VsIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
};

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) color: vec4<f32>,
};

@vertex
fn vs_main(in: VsIn) -> VsOut {
    var out: VsOut;
    out.clip = globals.world_to_clip * vec4<f32>(in.position, 1.0);
    out.world = in.position;
    out.normal = in.normal;
    out.uv = in.uv;
    out.color = in.color;
    return out;
}

struct FsOut {
    @location(0) color: vec4<f32>,
    @location(1) depth: f32,
    @location(2) source: u32,
};

// Marks a mesh pixel in the source target.
const SOURCE_MESH: u32 = 0xfffeu;

@fragment
fn fs_main(in: VsOut) -> FsOut {
    // Derivatives and the implicit-lod sample first, in uniform control flow.
    let face = cross(dpdx(in.world), dpdy(in.world));
    let texel = textureSample(base_color, base_sampler, in.uv);
    var toward = globals.view.xyz;
    if globals.view.w > 0.5 {
        toward = globals.view.xyz - in.world;
    }
    var g = face;
    if dot(g, toward) < 0.0 {
        g = -g;
    }
    var n = in.normal;
    if dot(n, g) < 0.0 {
        n = -n;
    }
    let len = length(n);
    if len > 0.0 {
        n = n / len;
    } else {
        n = normalize(g);
    }
    var base = material.factor * in.color;
    if material.alpha.z > 0.5 {
        base = base * texel;
    }
    if material.alpha.y > 0.5 && !(clamp(base.a, 0.0, 1.0) >= material.alpha.x) {
        discard;
    }
    let light = 0.3 + 0.7 * max(dot(n, globals.light.xyz), 0.0);
    var out: FsOut;
    out.color = vec4<f32>(base.rgb * light, 1.0);
    out.depth = in.clip.z;
    out.source = SOURCE_MESH;
    return out;
}
