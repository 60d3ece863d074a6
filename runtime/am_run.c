/* am_run.c -- the am-run program: starts a libam job (see am_launch.c). */
#include "config.h"

#include "am.h"

int main(int argc, char **argv)
{
    return am_launch_main(argc, argv, "am-run");
}
