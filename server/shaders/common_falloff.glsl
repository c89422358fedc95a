// Punctual light falloff (docs/lighting.md, "Spot light", "Barn doors and cookie"): the GLSL
// mirror of server/include/dfb/lightmath/Falloff.h, which must compute the same numbers
// (tests/gpu/lightmath_parity_test.cpp). KHR_lights_punctual (Khronos, 2018): intensity in candela
// with inverse-square attenuation; the cone is GLSL's smoothstep between the outer and inner cone
// cosines (the extension's note squares a linear ramp between the same two cosines).

// cosines = (cos outer, cos inner) as LightBlock::lightCone.xy holds them (inner > outer, so the
// smoothstep's edges are ordered); L: unit direction from the surface to the light; axis: the
// spot's unit direction. 0 outside the outer cone, 1 inside the inner one.
float spotCone(vec2 cosines, vec3 L, vec3 axis) {
    return smoothstep(cosines.x, cosines.y, dot(-L, axis));
}

// Inverse-square distance falloff (no range cut-off), d^2 clamped for a receiver at the light.
float inverseSquare(float dist2) {
    return 1.0 / max(dist2, 1e-12);
}

// Half-width of a barn door's soft edge: a quarter of a degree either side (Falloff.h
// BARN_DOOR_EDGE_RAD).
const float BARN_DOOR_EDGE_RAD = 0.00436332;

// Barn doors for the unit direction fromLight (light to point) in the light's frame (axis, right,
// up): each flap (doors = left, right, top, bottom half-angles in radians; >= 10 rad: open) cuts
// the light past its angle with a soft edge.
float barnDoors(vec3 axis, vec3 right, vec3 up, vec4 doors, vec3 fromLight) {
    float z = dot(fromLight, axis);
    if (z <= 0.0) return 0.0;
    float ax = atan(dot(fromLight, right), z), ay = atan(dot(fromLight, up), z);
    const float e = BARN_DOOR_EDGE_RAD;
    return (1.0 - smoothstep(doors.x - e, doors.x + e, -ax)) * (1.0 - smoothstep(doors.y - e, doors.y + e, ax)) *
           (1.0 - smoothstep(doors.z - e, doors.z + e, ay)) * (1.0 - smoothstep(doors.w - e, doors.w + e, -ay));
}
