#version 460
#extension GL_EXT_ray_tracing : require
// --mode rtpipeline: a shadow ray that met nothing (shadow_rtpipeline.rgen).
layout(location = 0) rayPayloadInEXT float payload_t;

void main() { payload_t = 2.0; }
