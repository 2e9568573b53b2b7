/* Serial port set-up: raw 8N1 at any protocol rate (termios2 on Linux, IOSSIOSPEED on macOS). */
#define _DEFAULT_SOURCE
#define _DARWIN_C_SOURCE
#include "nurimc_posix.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <unistd.h>

#if defined(__linux__)
#include <asm/termbits.h> /* struct termios2, BOTHER; not mixed with <termios.h> */

static nurimc_status configure(int fd, uint32_t baud) {
    struct termios2 tio;
    if (ioctl(fd, TCGETS2, &tio) != 0) return NURIMC_E_IO;
    tio.c_iflag &= ~(tcflag_t)(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON | IXOFF | IXANY);
    tio.c_oflag &= ~(tcflag_t)OPOST;
    tio.c_lflag &= ~(tcflag_t)(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
    tio.c_cflag &= ~(tcflag_t)(CSIZE | PARENB | CSTOPB | CRTSCTS | CBAUD | (CBAUD << IBSHIFT));
    tio.c_cflag |= CS8 | CREAD | CLOCAL | BOTHER | (BOTHER << IBSHIFT);
    tio.c_ispeed = baud;
    tio.c_ospeed = baud;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    if (ioctl(fd, TCSETS2, &tio) != 0) return NURIMC_E_IO;
    return NURIMC_OK;
}
#else
#include <termios.h>
#if defined(__APPLE__)
#include <IOKit/serial/ioss.h>
#endif

static speed_t standard_speed(uint32_t baud) {
    switch (baud) {
    case 110: return B110;
    case 300: return B300;
    case 600: return B600;
    case 1200: return B1200;
    case 2400: return B2400;
    case 4800: return B4800;
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
#ifdef B230400
    case 230400: return B230400;
#endif
    default: return 0;
    }
}

static nurimc_status configure(int fd, uint32_t baud) {
    struct termios tio;
    speed_t speed = standard_speed(baud);
    if (tcgetattr(fd, &tio) != 0) return NURIMC_E_IO;
    cfmakeraw(&tio);
    tio.c_cflag &= ~(tcflag_t)(CSTOPB | PARENB | CRTSCTS);
    tio.c_cflag |= CS8 | CREAD | CLOCAL;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
#if defined(__APPLE__)
    if (speed == 0) speed = B9600; /* placeholder; IOSSIOSPEED below sets the real rate */
#else
    if (speed == 0) return NURIMC_E_BAUD; /* no portable way to a non-standard rate here */
#endif
    cfsetispeed(&tio, speed);
    cfsetospeed(&tio, speed);
    if (tcsetattr(fd, TCSANOW, &tio) != 0) return NURIMC_E_IO;
#if defined(__APPLE__)
    {
        speed_t exact = (speed_t)baud;
        if (ioctl(fd, IOSSIOSPEED, &exact) != 0) return NURIMC_E_IO;
    }
#endif
    return NURIMC_OK;
}
#endif

nurimc_status nurimc_port_set_baud(nurimc_port *port, uint32_t baud) {
    nurimc_status status;
    if (port == NULL || port->fd < 0) return NURIMC_E_ARGUMENT;
    if (nurimc_baud_index(baud) < 0) return NURIMC_E_BAUD;
    status = configure(port->fd, baud);
    if (status == NURIMC_OK) port->baud = baud;
    return status;
}

/* One program per port, as the Python transport (pyserial's exclusive=True: flock) does: an
 * advisory lock every nurimc program takes, and TIOCEXCL so that other programs' opens fail
 * with EBUSY while we hold it (root is not stopped by TIOCEXCL; the flock still tells). */
static nurimc_status lock_port(int fd) {
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        if (errno == EWOULDBLOCK || errno == EAGAIN) {
            errno = EBUSY;
            return NURIMC_E_BUSY;
        }
        if (errno != ENOLCK && errno != EINVAL && errno != ENOTSUP) return NURIMC_E_IO;
    }
#ifdef TIOCEXCL
    (void)ioctl(fd, TIOCEXCL); /* best effort: not every device is a tty */
#endif
    return NURIMC_OK;
}

nurimc_status nurimc_port_open(nurimc_port *port, const char *path, uint32_t baud) {
    nurimc_status status;
    if (port == NULL || path == NULL) return NURIMC_E_ARGUMENT;
    port->fd = -1;
    port->baud = 0;
    if (nurimc_baud_index(baud) < 0) return NURIMC_E_BAUD;
    port->fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (port->fd < 0) return errno == EBUSY ? NURIMC_E_BUSY : NURIMC_E_IO; /* EBUSY: TIOCEXCL of another */
    status = lock_port(port->fd);
    if (status == NURIMC_OK) status = nurimc_port_set_baud(port, baud);
    if (status != NURIMC_OK) {
        int saved = errno;
        nurimc_port_close(port);
        errno = saved;
    }
    return status;
}

void nurimc_port_close(nurimc_port *port) {
    if (port != NULL && port->fd >= 0) {
#ifdef TIOCNXCL
        (void)ioctl(port->fd, TIOCNXCL); /* the next program may open it */
#endif
        close(port->fd);
        port->fd = -1;
    }
}

/* Discard bytes received but not read (stale answers, echoes). */
int nurimc_port_discard_input(const nurimc_port *port);
int nurimc_port_discard_input(const nurimc_port *port) {
#if defined(__linux__)
    return ioctl(port->fd, TCFLSH, TCIFLUSH);
#else
    return tcflush(port->fd, TCIFLUSH);
#endif
}
