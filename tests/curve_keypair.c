/*
 * curve_keypair.c -- prints a new CURVE key pair for tests/lan-netns.sh.
 *
 *   curve_keypair    prints "PUBLIC SECRET" (two Z85 keys of 40 characters)
 *
 * Exit status 0, or 77 (the test suite's "skipped") when this libzmq was
 * built without CURVE, or 1 if libzmq cannot make a key pair.
 */
#include <stdio.h>

#include <zmq.h>

int main(void)
{
    if (!zmq_has("curve")) {
        fprintf(stderr, "curve_keypair: this libzmq has no CURVE\n");
        return 77;
    }
    char pub[41], sec[41];
    if (zmq_curve_keypair(pub, sec) != 0) {
        fprintf(stderr, "curve_keypair: %s\n", zmq_strerror(zmq_errno()));
        return 1;
    }
    printf("%s %s\n", pub, sec);
    return 0;
}
