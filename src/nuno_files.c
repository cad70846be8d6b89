/* File-system helpers for safe output files (module safe_files): an
 * exclusive lock file, "is this the same file" and rename, with the reason
 * of a failure as text (strerror), which Fortran I/O cannot give. Plain
 * POSIX; called on one rank. Strings in are NUL-terminated; messages out
 * are NUL-terminated in buffers of msglen bytes. */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <libgen.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

/* Take an exclusive, non-blocking flock on path (created if missing) and
 * keep it open in *fd. Returns 0 on success, 1 when another process holds
 * it (msg: what the holder wrote into it), 2 on any other error (msg: the
 * cause). The lock goes with the process: a killed run leaves the file but
 * no lock. Because nuno_lock_release unlinks the file, a lock taken on a
 * file that was unlinked meanwhile is retried on the new one (the inode of
 * the open file must still be the one under the name). */
int nuno_lock_acquire(const char *path, int *fd, char *msg, int msglen)
{
  for (int attempt = 0; attempt < 100; attempt++) {
    struct stat a, b;
    int f = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (f < 0) {
      snprintf(msg, msglen, "%s", strerror(errno));
      return 2;
    }
    if (flock(f, LOCK_EX | LOCK_NB) != 0) {
      int e = errno;
      if (e == EWOULDBLOCK) {
        char who[128] = "";
        ssize_t n = pread(f, who, sizeof(who) - 1, 0);
        if (n > 0) {
          who[n] = '\0';
          who[strcspn(who, "\n")] = '\0';
        }
        snprintf(msg, msglen, "%s", who[0] ? who : "unknown process");
        close(f);
        return 1;
      }
      snprintf(msg, msglen, "flock: %s", strerror(e));
      close(f);
      return 2;
    }
    if (fstat(f, &a) == 0 && stat(path, &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino) {
      char host[64] = "?", line[160];
      gethostname(host, sizeof(host) - 1);
      int n = snprintf(line, sizeof(line), "pid %ld on %s\n", (long)getpid(), host);
      if (ftruncate(f, 0) == 0 && n > 0) {
        ssize_t w = pwrite(f, line, (size_t)n, 0);
        (void)w; /* the holder's name is only for the message of a second run */
      }
      *fd = f;
      msg[0] = '\0';
      return 0;
    }
    close(f); /* unlinked by its previous holder meanwhile: try the new file */
  }
  snprintf(msg, msglen, "the lock file keeps changing");
  return 2;
}

/* Drop the lock: unlink first, so that no one can lock the old inode after
 * the close and believe it is the current lock. */
void nuno_lock_release(const char *path, int fd)
{
  if (fd < 0) return;
  unlink(path);
  close(fd);
}

/* 1 when a and b name the same file: the same inode if both exist, else the
 * same resolved path (b may not exist yet: its directory is resolved). */
int nuno_same_file(const char *a, const char *b)
{
  struct stat sa, sb;
  char ra[PATH_MAX], rd[PATH_MAX], rb[PATH_MAX + NAME_MAX + 2];
  if (stat(a, &sa) == 0 && stat(b, &sb) == 0) return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
  if (!realpath(a, ra)) return 0;
  char *b1 = strdup(b), *b2 = strdup(b);
  int same = 0;
  if (b1 && b2 && realpath(dirname(b1), rd)) {
    snprintf(rb, sizeof(rb), "%s/%s", rd, basename(b2));
    same = strcmp(ra, rb) == 0;
  }
  free(b1);
  free(b2);
  return same;
}

/* 1 when path exists (as anything). */
int nuno_exists(const char *path)
{
  struct stat s;
  return stat(path, &s) == 0;
}

/* rename(from, to); 0 on success, else 1 with the cause in msg. */
int nuno_rename(const char *from, const char *to, char *msg, int msglen)
{
  if (rename(from, to) == 0) {
    msg[0] = '\0';
    return 0;
  }
  snprintf(msg, msglen, "%s", strerror(errno));
  return 1;
}

/* Bytes free for an unprivileged writer on the file system that holds
 * path (statvfs of its directory), or -1 when that cannot be told. For the
 * cause of a failed write: a full disk says nothing else. */
#include <sys/statvfs.h>
double nuno_free_bytes(const char *path)
{
  char          buf[PATH_MAX];
  struct statvfs s;
  snprintf(buf, sizeof(buf), "%s", path);
  if (statvfs(dirname(buf), &s) != 0) return -1.0;
  return (double)s.f_bavail * (double)s.f_frsize;
}
