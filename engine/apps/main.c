// penumbra: soft shadows from rectangular area lights, on Vulkan compute.
#include <stdio.h>
#include <string.h>

#include "apps/args.h"
#include "apps/commands.h"
#include "core/log.h"

static void print_help(void)
{
    printf("penumbra - soft shadows from rectangular area lights on Vulkan compute\n"
           "\n"
           "usage: penumbra <command> [options]\n"
           "\n"
           "commands:\n"
           "  render [SCENE]   render a glTF 2.0 scene (.gltf/.glb) or builtin:NAME to an EXR\n"
           "  build [SCENE]    build the N-tree and line spaces, upload the pools, report sizes and time\n"
           "  diff A.exr B.exr compare two renders: MAE, RMSE, p99, max, shares off by > 0.05 and 0.2\n"
           "  bench            measure speed and error of modes and trees side by side (and Embree)\n"
           "  demo [SCENE]     the same passes in a window, every frame, with live controls\n"
           "  info             list the Vulkan devices and the limits that matter\n"
           "  help             this text; `penumbra render --help` for render's options\n"
           "\n"
           "environment:\n"
           "  PN_DEVICE=I|NAME     pick the Vulkan device by index or name substring\n"
           "  PN_VALIDATION=1      enable the Khronos validation layer with synchronization\n"
           "                       validation; any warning or error makes the exit code 3\n"
           "\n"
           "exit codes: 0 ok, 1 failure (input, device, output), 2 invalid command line,\n"
           "            3 the validation layer reported messages\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        print_help();
        return PN_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "--help") || !strcmp(cmd, "-h") || !strcmp(cmd, "help")) {
        if (argc > 2 && !strcmp(argv[2], "render"))
            pn_print_render_help();
        else if (argc > 2 && !strcmp(argv[2], "build"))
            pn_print_build_help();
        else if (argc > 2 && !strcmp(argv[2], "diff"))
            pn_print_diff_help();
        else if (argc > 2 && !strcmp(argv[2], "bench"))
            pn_print_bench_help();
        else if (argc > 2 && !strcmp(argv[2], "demo"))
            pn_print_demo_help();
        else
            print_help();
        return PN_EXIT_OK;
    }
    if (!strcmp(cmd, "render"))
        return pn_cmd_render(argc - 2, argv + 2);
    if (!strcmp(cmd, "bench"))
        return pn_cmd_bench(argc - 2, argv + 2);
    if (!strcmp(cmd, "diff"))
        return pn_cmd_diff(argc - 2, argv + 2);
    if (!strcmp(cmd, "demo"))
        return pn_cmd_demo(argc - 2, argv + 2);
    if (!strcmp(cmd, "build"))
        return pn_cmd_build(argc - 2, argv + 2);
    if (!strcmp(cmd, "info"))
        return pn_cmd_info(argc - 2, argv + 2);
    pn_error("unknown command '%s' (see penumbra --help)", cmd);
    return PN_EXIT_USAGE;
}
