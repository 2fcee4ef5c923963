// The penumbra subcommands; each returns a process exit code (see args.h).
#pragma once

int pn_cmd_render(int argc, char **argv);
int pn_cmd_info(int argc, char **argv);
int pn_cmd_build(int argc, char **argv);
int pn_cmd_diff(int argc, char **argv);
int pn_cmd_bench(int argc, char **argv);
int pn_cmd_demo(int argc, char **argv);

void pn_print_render_help(void);
void pn_print_build_help(void);
void pn_print_diff_help(void);
void pn_print_bench_help(void);
void pn_print_demo_help(void);
