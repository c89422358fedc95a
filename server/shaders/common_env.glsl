// The environment light's parameterisation and spherical harmonics: the GLSL mirror of
// dfb/lightmath/Environment.h (envLatLong, octDecode) and SphericalHarmonics.h (shEvaluate,
// shUnshadowedTransfer), line for line (STYLE.md, "Shaders and CPU/GPU parity"). Include after
// common_brdf.glsl (PI).

// (u, v) of a unit direction in the map: u = 0.5 looks along -Z and grows towards +X, v = 0 is
// the top row (+Y). The map is uploaded with its top row at t = 0.
vec2 envLatLong(vec3 d) {
    return vec2(0.5 + atan(d.x, -d.z) / (2.0 * PI), acos(clamp(d.y, -1.0, 1.0)) / PI);
}

// The unit direction of octahedral coordinates e in [-1, 1]^2 (lightmath::octDecode): the
// G-buffer's bent specular direction.
vec3 octDecode(vec2 e) {
    vec3 d = vec3(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    if (d.z < 0.0) {
        vec2 f = vec2(1.0 - abs(d.y), 1.0 - abs(d.x));
        d.x = d.x >= 0.0 ? f.x : -f.x;
        d.y = d.y >= 0.0 ? f.y : -f.y;
    }
    return normalize(d);
}

// Y_0..Y_8 at the unit direction d (no Condon-Shortley phase).
void shEvaluate(vec3 d, out float y[9]) {
    y[0] = 0.282094791773878;
    y[1] = 0.488602511902920 * d.y;
    y[2] = 0.488602511902920 * d.z;
    y[3] = 0.488602511902920 * d.x;
    y[4] = 1.092548430592079 * d.x * d.y;
    y[5] = 1.092548430592079 * d.y * d.z;
    y[6] = 0.315391565252520 * (3.0 * d.z * d.z - 1.0);
    y[7] = 1.092548430592079 * d.x * d.z;
    y[8] = 0.546274215296040 * (d.x * d.x - d.y * d.y);
}

// The unshadowed diffuse transfer of normal N: Y_i(N) times the clamped cosine's band factor
// over pi (Ramamoorthi and Hanrahan 2001, eq. 8: 1, 2/3, 1/4).
void shUnshadowedTransfer(vec3 N, out float t[9]) {
    shEvaluate(N, t);
    for (int i = 1; i < 4; ++i) t[i] *= 2.0 / 3.0;
    for (int i = 4; i < 9; ++i) t[i] *= 0.25;
}
