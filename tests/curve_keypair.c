/*
 * curve_keypair.c -- prints CURVE keys for tests/lan-netns.sh.
 *
 *   curve_keypair        prints "PUBLIC SECRET" (two Z85 keys of 40 characters)
 *   curve_keypair -n P   prints a libam key block for a job of P PEs, with
 *                        every PE's secret key: a file every PE of a job
 *                        started by hand can read (AM_CURVE_KEYS=FILE; format
 *                        in runtime/CONTROL.md, "CURVE and ZAP")
 *
 * Exit status 0, or 77 (the test suite's "skipped") when this libzmq was
 * built without CURVE, 2 for bad arguments, or 1 if libzmq cannot make a
 * key pair.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zmq.h>

int main(int argc, char **argv)
{
    long n = 0;
    if (argc == 3 && !strcmp(argv[1], "-n")) {
        char *end;
        n = strtol(argv[2], &end, 10);
        if (*end || n < 1 || n > 65536)
            n = -1;
    }
    if (argc != 1 && n <= 0) {
        fprintf(stderr, "usage: curve_keypair [-n P]\n");
        return 2;
    }
    if (!zmq_has("curve")) {
        fprintf(stderr, "curve_keypair: this libzmq has no CURVE\n");
        return 77;
    }
    char (*pub)[41] = calloc((size_t)(n ? n : 1), sizeof *pub);
    char (*sec)[41] = calloc((size_t)(n ? n : 1), sizeof *sec);
    if (!pub || !sec)
        return 1;
    for (long r = 0; r < (n ? n : 1); r++) {
        if (zmq_curve_keypair(pub[r], sec[r]) != 0) {
            fprintf(stderr, "curve_keypair: %s\n", zmq_strerror(zmq_errno()));
            return 1;
        }
    }
    if (!n) {
        printf("%s %s\n", pub[0], sec[0]);
    } else {
        printf("am-curve-keys 1\n");
        for (long r = 0; r < n; r++)
            printf("public %ld %s\n", r, pub[r]);
        for (long r = 0; r < n; r++)
            printf("secret %ld %s\n", r, sec[r]);
        printf("end\n");
    }
    free(pub);
    free(sec);
    return 0;
}
