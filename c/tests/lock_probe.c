/* Opens a port with the C library and says what happened ("ok" or the status name); with
 * "hold", keeps it open until stdin closes. Used by python/tests/transport/test_c_lock.py to
 * check the C and Python libraries refuse each other's ports. */
#include <stdio.h>
#include <string.h>

#include "nurimc_posix.h"

int main(int argc, char **argv) {
    nurimc_port port;
    nurimc_status status;
    if (argc < 2) {
        fprintf(stderr, "usage: lock_probe PATH [hold]\n");
        return 2;
    }
    status = nurimc_port_open(&port, argv[1], 9600);
    printf("%s\n", nurimc_status_name(status));
    fflush(stdout);
    if (status != NURIMC_OK) return 1;
    if (argc > 2 && strcmp(argv[2], "hold") == 0) {
        while (getchar() != EOF) {}
    }
    nurimc_port_close(&port);
    return 0;
}
