#version 450 core
// Deforms every shadow-casting vertex once per chain edit (eqs. 4-7), for the deformed shadow
// map's tessellation stages: out[2v] = (Q', 1 if mapped), out[2v+1] = (the local bending
// curvature kappa_eff (1/length), the foot's segment, the lateral growth rho / R, 0): what the
// control stage sizes its edge levels with (bendyEdgeLevel).
#include "common_uniforms.glsl"
#include "common_bendy.glsl"

layout(local_size_x = COMPUTE_GROUP_SIZE) in;
layout(std430, binding = SSBO_CASTER_POSITIONS) readonly buffer Casters { float casterXyz[]; };
layout(std430, binding = SSBO_DEFORMED) writeonly buffer Deformed { vec4 deformed[]; };
layout(location = LOC_DEFORM_VERTEX_COUNT) uniform uint uVertexCount;

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= uVertexCount) return;
    vec3 q = vec3(casterXyz[3u * v], casterXyz[3u * v + 1u], casterXyz[3u * v + 2u]);
    TubeCoords c = inverseMap(q);
    if (!c.valid) {
        deformed[2u * v] = vec4(uBendy.bendyP[0].xyz, 0.0);
        deformed[2u * v + 1u] = vec4(0.0);
        return;
    }
    // A straight edge near Q bends in the deformed space about as much as the chain turns there
    // (curvature kappa = |P' x P''| / |P'|^3), scaled by how much the lateral offsets grow
    // (rho / R: the cone's radius over the tube's).
    vec3 d = c.derivative.xyz;
    float speed = max(length(d), 1e-20);
    float kappa = length(cross(d, segmentSecondDerivative(c.g))) / (speed * speed * speed);
    float s = tubeArcLength(c);
    float R = max(c.foot.w, 1e-20);
    float ratio = s * uBendy.bendyAxisU.w / R;
    // Eq. 7 scales a lateral offset rho by f(s) = s tan(theta) / R(s): where the radius does not
    // grow as s tan(theta) (a bent chain's radii, the extension's slope) a straight edge along
    // the tube bends by rho f''(s) even where the chain is straight. With R_s = R_t / |P_t| and
    // R_ss ~ R_tt / |P_t|^2: f'' = -tan(theta) (s R_ss / R^2 + 2 R_s (R - s R_s) / R^3).
    float Rs = c.derivative.w / speed, Rss = 2.0 * (c.g.p0.w - 2.0 * c.g.p1.w + c.g.p2.w) / (speed * speed);
    float rho = length(vec2(c.v, c.w)) * R;
    float kappaRadius = rho * uBendy.bendyAxisU.w * abs(s * Rss / (R * R) + 2.0 * Rs * (R - s * Rs) / (R * R * R));
    deformed[2u * v] = vec4(deformedPointAt(c, s), 1.0);
    deformed[2u * v + 1u] = vec4(kappa * max(ratio, 1.0) + kappaRadius, float(c.segment), ratio, 0.0);
}
