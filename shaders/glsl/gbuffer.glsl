// Shared by gbuffer.vert/.frag: the per-draw push constants, GBufferPush in interface.h.
#include "interface.h"

layout(push_constant) uniform GBufferPushBlock { GBufferPush pc; };
