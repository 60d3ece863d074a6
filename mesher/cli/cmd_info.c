/* cli/cmd_info.c -- 'pdr info': versions and build configuration, for bug
 * reports and for checking what a machine's build can do. */
#include "config.h"

#include <event2/event.h>
#include <getopt.h>
#include <metis.h>
#include <stdio.h>
#include <zmq.h>

#include "am.h"
#include "cli/pdr_cli.h"
#include "pr.h"

int pdr_cmd_info(int argc, char **argv)
{
    static const struct option opts[] = {{"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
        switch (c) {
        case 'h':
            printf("Usage: pdr info\n\n"
                   "Prints the versions of pdr and of the libraries it runs "
                   "on, and how it was built.\n");
            return PDR_EXIT_OK;
        default:
            return PDR_EXIT_USAGE;
        }
    }
    if (optind != argc) {
        pdr_cli_error("info", "unexpected argument '%s'", argv[optind]);
        return PDR_EXIT_USAGE;
    }

    int zmaj, zmin, zpat;
    zmq_version(&zmaj, &zmin, &zpat);
    printf("pdr            %s\n", PACKAGE_VERSION);
    printf("libam          %s\n", am_version());
    printf("wire protocol  version %d, %d-byte frame header\n", PR_VERSION,
           PR_HEADER_SIZE);
    printf("libzmq         %d.%d.%d\n", zmaj, zmin, zpat);
    printf("libevent       %s\n", event_get_version());
    printf("METIS          %d.%d.%d, idx_t %d bits\n", METIS_VER_MAJOR,
           METIS_VER_MINOR, METIS_VER_SUBMINOR, PDR_METIS_IDXTYPEWIDTH);
    printf("compiler       %s\n", __VERSION__);
#ifdef __FP_FAST_FMA
    printf("fma            hardware FMA available; contraction disabled\n");
#endif
    return PDR_EXIT_OK;
}
