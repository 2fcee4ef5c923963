// Sanitizer builds only (tests/CMakeLists.txt, tests/sanitizers.md): LD_PRELOADed into every test
// process. The Vulkan loader dlclose()s the driver and the layers in vkDestroyInstance, so when
// LeakSanitizer reports at exit their leaked allocations come from "<unknown module>" and
// tests/lsan.supp, which matches them by library name, cannot suppress them. This pins those
// libraries (PN_SAN_PIN, a colon-separated list of paths) before main:
// - RTLD_NODELETE: the loader's later dlopen() gets the same object and its dlclose() no longer
//   unmaps it, so the frames keep their module names;
// - RTLD_LOCAL: their symbols stay out of the global scope. (Plain LD_PRELOAD of the libraries
//   would put the validation layer's exported vkGetInstanceProcAddr and
//   vkEnumerateInstanceExtensionProperties ahead of the loader's, for penumbra and for GLFW.)
// Built without sanitizers: it is also preloaded into the shells and tools the tests run, where
// it does nothing.
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stdlib.h>
#include <string.h>

__attribute__((constructor)) static void pn_san_pin(void)
{
    // Only processes LeakSanitizer watches (penumbra, the C tests) need the pins.
    if (!dlsym(RTLD_DEFAULT, "__lsan_do_leak_check"))
        return;
    const char *list = getenv("PN_SAN_PIN");
    if (!list)
        return;
    char path[4096];
    while (*list) {
        size_t n = strcspn(list, ":");
        if (n > 0 && n < sizeof path) {
            memcpy(path, list, n);
            path[n] = '\0';
            dlopen(path, RTLD_LAZY | RTLD_LOCAL | RTLD_NODELETE); // a missing library: nothing to pin
        }
        list += n + (list[n] == ':');
    }
}
