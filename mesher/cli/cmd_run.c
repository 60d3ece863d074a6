/* cli/cmd_run.c -- 'pdr run': starts a program as a libam job, exactly like
 * am-run (the launcher lives in libam; see runtime/am_launch.c). */
#include "config.h"

#include "am.h"
#include "cli/pdr_cli.h"

int pdr_cmd_run(int argc, char **argv)
{
    return am_launch_main(argc, argv, "pdr run");
}
