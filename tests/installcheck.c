/* Built by 'make installcheck' against the installed libam, through
 * pkg-config only, to prove that another program can use the runtime. */
#include <am.h>
#include <stdio.h>
#include <string.h>

int main(void)
{
    if (strcmp(am_strerror(AM_EINVAL), "invalid argument") != 0)
        return 1;
    printf("installed libam %s works\n", am_version());
    return 0;
}
