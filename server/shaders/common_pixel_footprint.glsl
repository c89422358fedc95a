// Edges inside a pixel (docs/lighting.md, "Edges inside a pixel"): a merged G-buffer sample stands
// for the bake's samples of one surface in its pixel, so a light's mask -- visibility, cone, barn
// doors, cookie -- is averaged over taps spread across the sample's pixel footprint instead of
// being looked up once at the merged position. The footprint is the pixel's on the sample's
// tangent plane, from the bake camera's ray differentials (Igehy, "Tracing Ray Differentials",
// SIGGRAPH 1999, section 3.1: transfer of a differential to a plane); the taps are the bake's own
// sample offsets (uView.footprintTaps), shrunk by sqrt(A) for partial coverage. Include after
// common_uniforms.glsl and the declaration of uPixelStep.

// The engine's variants define the tap count (1 in preview frames); the generic shaders read it.
#ifndef SHADE_FOOTPRINT_TAPS
#define SHADE_FOOTPRINT_TAPS (uPixelStep > 1 ? 1 : uView.sampleLayout.z)
#endif

// The sample's footprint: columns dP/dx (one pixel right) and dP/dy (one row down) on the plane
// through P with normal Ng, scaled by sqrt(coverage) (a partially covering sample's bake samples
// cover that fraction of the pixel around their mean P). With the ray P = E + t D (t = 1 at P,
// D = P - E; orthographic: D = the view direction and the origin moves instead) and u the
// change of t D (or of the origin) per pixel, Igehy's transfer is dP = u - D (u . Ng) / (D . Ng).
// Normals face the camera (D . Ng < 0); grazing footprints are capped at 20 pixels' length.
mat2x3 pixelFootprint(vec3 P, vec3 Ng, float coverage) {
    bool ortho = uView.cameraPosition.w > 0.5;
    vec3 D = ortho ? uView.cameraForward.xyz : P - uView.cameraPosition.xyz;
    float depth = ortho ? 1.0 : dot(D, uView.cameraForward.xyz);
    float pixel = uView.cameraRight.w * depth * sqrt(clamp(coverage, 0.0, 1.0));
    vec3 ux = uView.cameraRight.xyz * pixel, uy = uView.cameraDown.xyz * pixel;
    float dn = min(dot(D, Ng), -0.05 * length(D));
    return mat2x3(ux - D * (dot(ux, Ng) / dn), uy - D * (dot(uy, Ng) / dn));
}

// Tap k's offset from P (world units) in the footprint `fp`.
vec3 footprintTap(mat2x3 fp, int k) {
    vec4 pair = uView.footprintTaps[k >> 1];
    return fp * ((k & 1) == 0 ? pair.xy : pair.zw);
}
