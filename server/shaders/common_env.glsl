// The environment light's parameterisation and spherical harmonics: the GLSL mirror of
// dfb/lightmath/Environment.h (envLatLong, octDecode) and SphericalHarmonics.h (shEvaluate,
// shEvaluate25, shUnshadowedTransfer, shUnshadowedTransfer25), line for line (STYLE.md, "Shaders
// and CPU/GPU parity"). Include after common_brdf.glsl (PI).

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

// Y_0..Y_24 at the unit direction d: shEvaluate's nine, then bands 3 and 4 (SphericalHarmonics.h
// shEvaluate25).
void shEvaluate25(vec3 d, out float y[25]) {
    float nine[9];
    shEvaluate(d, nine);
    for (int i = 0; i < 9; ++i) y[i] = nine[i];
    float x = d.x, v = d.y, z = d.z, x2 = x * x, v2 = v * v, z2 = z * z;
    y[9] = 0.590043589926644 * v * (3.0 * x2 - v2);
    y[10] = 2.890611442640554 * x * v * z;
    y[11] = 0.457045799464466 * v * (5.0 * z2 - 1.0);
    y[12] = 0.373176332590115 * z * (5.0 * z2 - 3.0);
    y[13] = 0.457045799464466 * x * (5.0 * z2 - 1.0);
    y[14] = 1.445305721320277 * z * (x2 - v2);
    y[15] = 0.590043589926644 * x * (x2 - 3.0 * v2);
    y[16] = 2.503342941796705 * x * v * (x2 - v2);
    y[17] = 1.770130769779930 * v * z * (3.0 * x2 - v2);
    y[18] = 0.946174695757560 * x * v * (7.0 * z2 - 1.0);
    y[19] = 0.669046543557289 * v * z * (7.0 * z2 - 3.0);
    y[20] = 0.105785546915204 * (35.0 * z2 * z2 - 30.0 * z2 + 3.0);
    y[21] = 0.669046543557289 * x * z * (7.0 * z2 - 3.0);
    y[22] = 0.473087347878780 * (x2 - v2) * (7.0 * z2 - 1.0);
    y[23] = 1.770130769779930 * x * z * (x2 - 3.0 * v2);
    y[24] = 0.625835735449176 * (x2 * (x2 - 3.0 * v2) - v2 * (3.0 * x2 - v2));
}

// shUnshadowedTransfer on five bands: band factors 1, 2/3, 1/4, 0, -1/24 (Ramamoorthi and
// Hanrahan 2001, eq. 8).
void shUnshadowedTransfer25(vec3 N, out float t[25]) {
    shEvaluate25(N, t);
    for (int i = 1; i < 4; ++i) t[i] *= 2.0 / 3.0;
    for (int i = 4; i < 9; ++i) t[i] *= 0.25;
    for (int i = 9; i < 16; ++i) t[i] = 0.0;
    for (int i = 16; i < 25; ++i) t[i] *= -1.0 / 24.0;
}
