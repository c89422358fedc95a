#version 450 core
// Depth only; slope-scaled polygon offset is set by the engine.
void main() {}
