// Just enough JSON writing for penumbra's machine-readable outputs.
#pragma once
#include <stdio.h>

// Writes `s` as a quoted JSON string with escapes.
void pn_json_string(FILE *f, const char *s);
