#version 450 core
// Bake pass: evaluates a glTF 2.0 metallic-roughness material (with KHR_materials_specular,
// _sheen, _clearcoat, _emissive_strength and KHR_texture_transform) at the sample and writes one
// G-buffer sample (docs/gbuffer-format.md). Paper 004 section 4.1: every spatially varying input
// is evaluated here, so the relight loop only evaluates BRDFs.
in vec3 vPosition;
in vec3 vNormal;
in vec4 vTangent;
in vec2 vUv0;
in vec2 vUv1;
in vec4 vColor;

// Texture slots; bit i of uTexMask says whether slot i is bound.
#define SLOT_BASE_COLOR 0
#define SLOT_METALLIC_ROUGHNESS 1
#define SLOT_NORMAL 2
#define SLOT_OCCLUSION 3
#define SLOT_EMISSIVE 4
#define SLOT_SPECULAR 5
#define SLOT_SPECULAR_COLOR 6
#define SLOT_SHEEN_COLOR 7
#define SLOT_SHEEN_ROUGHNESS 8
#define SLOT_CLEARCOAT 9
#define SLOT_CLEARCOAT_ROUGHNESS 10
#define SLOT_COUNT 11

layout(binding = 0) uniform sampler2D uTex[SLOT_COUNT];

layout(location = 1) uniform vec3 uCameraPosition;
layout(location = 2) uniform vec3 uCameraForward;
layout(location = 3) uniform int uOrthographic;
layout(location = 4) uniform vec4 uBaseColor;
layout(location = 5) uniform vec4 uBrdf;      // metallic, roughness, specular level, occlusion strength
layout(location = 6) uniform vec3 uEmission;  // emissive factor * emissive strength
layout(location = 7) uniform vec4 uSheen;     // colour rgb, roughness
layout(location = 8) uniform vec2 uCoat;      // weight, roughness
layout(location = 9) uniform vec3 uSpecularColor;
layout(location = 10) uniform vec2 uIds;      // object, material (as floats: exact below 2^24)
layout(location = 11) uniform int uAlphaMode; // 0 opaque, 1 mask, 2 blend
layout(location = 12) uniform float uAlphaCutoff;
layout(location = 13) uniform float uNormalScale;
layout(location = 14) uniform int uTexMask;
layout(location = 15) uniform int uTexCoord[SLOT_COUNT];
layout(location = 26) uniform mat3 uTexTransform[SLOT_COUNT];

layout(location = 0) out vec4 oPosition;   // P.xyz, coat roughness
layout(location = 1) out vec4 oNormal;     // N.xyz, alpha (coverage of BLEND materials)
layout(location = 2) out vec4 oGeomNormal; // Ng.xyz, object id
layout(location = 3) out vec4 oTangent;    // T.xyzw
layout(location = 4) out vec4 oAlbedo;     // albedo.rgb, material id
layout(location = 5) out vec4 oBrdf;       // metallic, roughness, specular, occlusion
layout(location = 6) out vec4 oEmission;   // emission.rgb, coat weight
layout(location = 7) out vec4 oSheen;      // sheen.rgb, sheen roughness

bool hasTex(int slot) { return (uTexMask & (1 << slot)) != 0; }

vec4 sampleSlot(int slot) {
    vec2 uv = uTexCoord[slot] == 1 ? vUv1 : vUv0;
    uv = (uTexTransform[slot] * vec3(uv, 1.0)).xy; // KHR_texture_transform
    // Indexing a sampler array needs a constant or dynamically uniform index: slot is a constant
    // at every call site.
    return texture(uTex[slot], uv);
}

void main() {
    vec4 base = uBaseColor * vColor;
    if (hasTex(SLOT_BASE_COLOR)) base *= sampleSlot(SLOT_BASE_COLOR); // sRGB texture: decoded by GL
    if (uAlphaMode == 1 && base.a < uAlphaCutoff) discard;
    float alpha = uAlphaMode == 2 ? clamp(base.a, 0.0, 1.0) : 1.0;

    vec3 toEye = uOrthographic != 0 ? -uCameraForward : normalize(uCameraPosition - vPosition);
    vec3 ng = normalize(cross(dFdx(vPosition), dFdy(vPosition)));
    if (dot(ng, toEye) < 0.0) ng = -ng;

    // Shading frame; back faces of double-sided materials flip it (glTF doubleSided).
    vec3 n = normalize(vNormal);
    vec3 t = vTangent.xyz - n * dot(n, vTangent.xyz);
    t = dot(t, t) > 1e-12 ? normalize(t) : normalize(cross(abs(n.x) < 0.9 ? vec3(1, 0, 0) : vec3(0, 1, 0), n));
    float handedness = vTangent.w < 0.0 ? -1.0 : 1.0;
    if (!gl_FrontFacing) { n = -n; t = -t; }
    vec3 b = cross(n, t) * handedness;
    if (hasTex(SLOT_NORMAL)) {
        vec3 m = sampleSlot(SLOT_NORMAL).xyz * 2.0 - 1.0;
        m.xy *= uNormalScale;
        n = normalize(mat3(t, b, n) * m);
        t = normalize(t - n * dot(n, t));
    }
    if (dot(n, toEye) < 0.0) {
        // Interpolated or mapped normals can face away at grazing angles; bend them back to the
        // horizon so that the stored normal faces the camera (documented in gbuffer-format.md).
        n = normalize(n - dot(n, toEye) * toEye * 1.001);
        t = normalize(t - n * dot(n, t));
    }

    float metallic = uBrdf.x, roughness = uBrdf.y;
    if (hasTex(SLOT_METALLIC_ROUGHNESS)) {
        vec4 mr = sampleSlot(SLOT_METALLIC_ROUGHNESS);
        roughness *= mr.g;
        metallic *= mr.b;
    }
    float occlusion = 1.0;
    if (hasTex(SLOT_OCCLUSION)) occlusion = 1.0 + uBrdf.w * (sampleSlot(SLOT_OCCLUSION).r - 1.0);
    vec3 emission = uEmission;
    if (hasTex(SLOT_EMISSIVE)) emission *= sampleSlot(SLOT_EMISSIVE).rgb;
    // KHR_materials_specular: F0 = 0.04 * specularColor * specularFactor; stored as the scalar
    // level s with F0 = 0.08 * s, the colour reduced to its mean (format v2 stores no colour).
    float specular = uBrdf.z;
    vec3 specColor = uSpecularColor;
    if (hasTex(SLOT_SPECULAR)) specular *= sampleSlot(SLOT_SPECULAR).a;
    if (hasTex(SLOT_SPECULAR_COLOR)) specColor *= sampleSlot(SLOT_SPECULAR_COLOR).rgb;
    specular = clamp(specular * dot(specColor, vec3(1.0 / 3.0)), 0.0, 1.0);
    vec4 sheen = uSheen;
    if (hasTex(SLOT_SHEEN_COLOR)) sheen.rgb *= sampleSlot(SLOT_SHEEN_COLOR).rgb;
    if (hasTex(SLOT_SHEEN_ROUGHNESS)) sheen.a *= sampleSlot(SLOT_SHEEN_ROUGHNESS).a;
    vec2 coat = uCoat;
    if (hasTex(SLOT_CLEARCOAT)) coat.x *= sampleSlot(SLOT_CLEARCOAT).r;
    if (hasTex(SLOT_CLEARCOAT_ROUGHNESS)) coat.y *= sampleSlot(SLOT_CLEARCOAT_ROUGHNESS).g;

    oPosition = vec4(vPosition, coat.y);
    oNormal = vec4(n, alpha);
    oGeomNormal = vec4(ng, uIds.x);
    oTangent = vec4(t, handedness);
    oAlbedo = vec4(clamp(base.rgb, 0.0, 1.0), uIds.y);
    oBrdf = vec4(clamp(metallic, 0.0, 1.0), clamp(roughness, 0.0, 1.0), specular, clamp(occlusion, 0.0, 1.0));
    oEmission = vec4(max(emission, vec3(0.0)), clamp(coat.x, 0.0, 1.0));
    oSheen = vec4(clamp(sheen.rgb, 0.0, 1.0), clamp(sheen.a, 0.0, 1.0));
}
