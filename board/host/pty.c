/* The host build's pseudo-terminal: the firmware holds the master end, the host opens the
 * slave through a symlink (a path, like a USB serial port), as the Python mock does
 * (hand_service/firmware/ports.py). */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include "host.h"

int host_pty_open(const char *link_path, char *device, uint32_t device_len)
{
    const int fd = posix_openpt(O_RDWR | O_NOCTTY);
    if (fd < 0 || grantpt(fd) != 0 || unlockpt(fd) != 0) {
        return -1;
    }
    const char *name = ptsname(fd);
    if (name == NULL || strlen(name) + 1u > device_len) {
        close(fd);
        return -1;
    }
    snprintf(device, device_len, "%s", name);
    /* raw, no echo, before the host opens it; the slave stays open here so that the master
     * never reads EIO while no host holds it */
    const int slave = open(device, O_RDWR | O_NOCTTY);
    struct termios tio;
    if (slave < 0 || tcgetattr(slave, &tio) != 0) {
        close(fd);
        return -1;
    }
    tio.c_iflag &= (tcflag_t) ~(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON);
    tio.c_oflag &= (tcflag_t)~OPOST;
    tio.c_lflag &= (tcflag_t) ~(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
    tio.c_cflag &= (tcflag_t) ~(CSIZE | PARENB);
    tio.c_cflag |= CS8;
    tio.c_cc[VMIN] = 1;
    tio.c_cc[VTIME] = 0;
    if (tcsetattr(slave, TCSANOW, &tio) != 0) {
        close(slave);
        close(fd);
        return -1;
    }
    const int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) {
        close(slave);
        close(fd);
        return -1;
    }
    struct stat st;
    if (lstat(link_path, &st) == 0) {
        if (!S_ISLNK(st.st_mode)) {
            errno = EEXIST; /* never replace a file that is not our symlink */
            close(slave);
            close(fd);
            return -1;
        }
        unlink(link_path); /* left by an earlier run */
    }
    if (symlink(device, link_path) != 0) {
        close(slave);
        close(fd);
        return -1;
    }
    return fd; /* the slave fd stays open for the process's life, on purpose */
}

void host_pty_write(int fd, const uint8_t *data, uint32_t len)
{
    const ssize_t written = write(fd, data, len);
    host.dropped_bytes += written < 0 ? len : len - (uint32_t)written;
}
