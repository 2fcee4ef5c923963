#version 460
#extension GL_EXT_ray_tracing : require
// --mode rtpipeline: the hit that ended a shadow ray (TerminateOnFirstHit), its t on the segment
// for the blocker image (shadow_rtpipeline.rgen).
layout(location = 0) rayPayloadInEXT float payload_t;

void main() { payload_t = gl_HitTEXT; }
