#version 450 core
// Bake pass: writes one G-buffer sample per pixel (docs/gbuffer-format.md). Factors only in v0.
in vec3 vPosition;
in vec3 vNormal;
in float vDepth;

layout(location = 2) uniform vec4 uBaseColor;
layout(location = 3) uniform vec4 uBrdf;       // metallic, roughness, specular, occlusion
layout(location = 4) uniform vec3 uEmission;
layout(location = 5) uniform uvec2 uIds;       // object, material
layout(location = 6) uniform vec3 uCameraPosition;

layout(location = 0) out vec4 oPositionDepth; // xyz = P, w = Z
layout(location = 1) out vec4 oNormal;        // xyz = N
layout(location = 2) out vec4 oGeomNormal;    // xyz = Ng
layout(location = 3) out vec4 oAlbedo;        // rgb = albedo, a = coverage
layout(location = 4) out vec4 oBrdf;
layout(location = 5) out vec4 oEmission;
layout(location = 6) out uvec2 oIds;

void main() {
    vec3 ng = normalize(cross(dFdx(vPosition), dFdy(vPosition)));
    vec3 toEye = uCameraPosition - vPosition;
    // Two-sided surfaces seen from the back are shaded with flipped normals (glTF doubleSided).
    if (dot(ng, toEye) < 0.0) ng = -ng;
    vec3 n = normalize(vNormal);
    if (!gl_FrontFacing) n = -n;
    if (dot(n, toEye) < 0.0 && dot(ng, toEye) > 0.0) {
        // Interpolated normals can face away at silhouettes; bend them back towards the viewer.
        n = normalize(n - dot(n, normalize(toEye)) * normalize(toEye) * 1.001);
    }
    oPositionDepth = vec4(vPosition, vDepth);
    oNormal = vec4(n, 0.0);
    oGeomNormal = vec4(ng, 0.0);
    oAlbedo = vec4(uBaseColor.rgb, 1.0);
    oBrdf = uBrdf;
    oEmission = vec4(uEmission, 0.0);
    oIds = uIds;
}
