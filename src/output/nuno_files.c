// SPDX-License-Identifier: BSD-2-Clause
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

/* Whether the open file f may serve as a lock: a regular file of at most
 * 255 bytes that is empty (a fresh or a killed run's) or holds one line
 * "pid N on HOST" (what this function's writer puts there). Anything else
 * is a user's file that happens to have the lock's name: not ours. */
static int is_lock_file(int f)
{
  struct stat s;
  char        buf[256];
  long        pid;
  if (fstat(f, &s) != 0 || !S_ISREG(s.st_mode) || s.st_size > 255) return 0;
  ssize_t n = pread(f, buf, sizeof(buf) - 1, 0);
  if (n < 0) return 0;
  buf[n] = '\0';
  if (n == 0) return 1;
  char host[200];
  return sscanf(buf, "pid %ld on %199s", &pid, host) == 2 && pid > 0 && buf[n - 1] == '\n' && strchr(buf, '\n') == buf + n - 1;
}

/* Take an exclusive, non-blocking flock on path and keep it open in *fd.
 * The file is created exclusively (O_EXCL: never through a symbolic link);
 * an existing one is reused only when it is a lock file (is_lock_file: a
 * killed run leaves one) and is opened with O_NOFOLLOW. Returns 0 on
 * success, 1 when another process holds it (msg: what the holder wrote into
 * it), 2 on any other error (msg: the cause), 3 when the name is taken by
 * something that is not a lock file (msg: what it is). The lock goes with
 * the process: a killed run leaves the file but no lock. Because
 * nuno_lock_release unlinks the file, a lock taken on a file that was
 * unlinked meanwhile is retried on the new one (the inode of the open file
 * must still be the one under the name). */
int nuno_lock_acquire(const char *path, int *fd, char *msg, int msglen)
{
  for (int attempt = 0; attempt < 100; attempt++) {
    struct stat a, b;
    int f = open(path, O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
    if (f < 0 && errno == EEXIST) {
      f = open(path, O_RDWR | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK);
      if (f < 0 && (errno == ELOOP || errno == EMLINK)) {
        snprintf(msg, msglen, "it is a symbolic link");
        return 3;
      }
      if (f < 0 && errno == ENOENT) continue; /* released meanwhile: create it */
      if (f >= 0 && !is_lock_file(f)) {
        close(f);
        snprintf(msg, msglen, "it exists and is not a lock file of nuno");
        return 3;
      }
    }
    if (f < 0) {
      if (errno == EISDIR) {
        snprintf(msg, msglen, "it is a directory");
        return 3;
      }
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
    if (fstat(f, &a) == 0 && lstat(path, &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino) {
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
  struct stat a, b;
  if (fd < 0) return;
  /* only the file this lock is (not what took its name meanwhile) */
  if (fstat(fd, &a) == 0 && lstat(path, &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino) unlink(path);
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

/* 1 when path exists (as anything, a dangling symbolic link included). */
int nuno_exists(const char *path)
{
  struct stat s;
  return lstat(path, &s) == 0;
}

/* What the name path itself is (lstat: a symbolic link is not followed):
 * 0 nothing, 1 a regular file, 2 a symbolic link, 3 a directory, 4 anything
 * else (a fifo, a socket, a device), 5 cannot be told (msg: the cause). */
int nuno_path_kind(const char *path, char *msg, int msglen)
{
  struct stat s;
  msg[0] = '\0';
  if (lstat(path, &s) != 0) {
    if (errno == ENOENT) return 0;
    snprintf(msg, msglen, "%s", strerror(errno));
    return 5;
  }
  if (S_ISREG(s.st_mode)) return 1;
  if (S_ISLNK(s.st_mode)) return 2;
  if (S_ISDIR(s.st_mode)) return 3;
  return 4;
}

/* Remove path when it is a regular file (never a symbolic link or a
 * directory): for files this run made. 0 removed or absent, 1 not removed
 * (msg: why). */
int nuno_remove_file(const char *path, char *msg, int msglen)
{
  struct stat s;
  msg[0] = '\0';
  if (lstat(path, &s) != 0) return errno == ENOENT ? 0 : (snprintf(msg, msglen, "%s", strerror(errno)), 1);
  if (!S_ISREG(s.st_mode)) {
    snprintf(msg, msglen, "not a regular file");
    return 1;
  }
  if (unlink(path) != 0 && errno != ENOENT) {
    snprintf(msg, msglen, "%s", strerror(errno));
    return 1;
  }
  return 0;
}

/* rename(from, to); 0 on success, else 1 with the cause in msg. rename(2)
 * replaces the name `to` itself, never the file a symbolic link there
 * points to; `to` must not be a symbolic link or a directory all the same
 * (nuno replaces only files it made, checked at the start: this is the
 * last guard against a link put there meanwhile). */
int nuno_rename(const char *from, const char *to, char *msg, int msglen)
{
  struct stat s;
  if (lstat(to, &s) == 0 && !S_ISREG(s.st_mode)) {
    snprintf(msg, msglen, "%s is not a regular file (a symbolic link or a directory)", to);
    return 1;
  }
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

/* A side file written whole and put in place atomically (the XDMF
 * sidecar): nuno_tmp_open creates a new file beside path, exclusively
 * (mkstemp: O_EXCL, a fresh random name, never a symbolic link), with its
 * name in tmp (tmplen bytes); nuno_tmp_write appends n bytes; nuno_tmp_commit
 * closes it and renames it onto path (nuno_rename: never through a link),
 * or with ok = 0 removes it. Return 0 on success, else 1 with the cause in msg. */
int nuno_tmp_open(const char *path, char *tmp, int tmplen, int *fd, char *msg, int msglen)
{
  if (snprintf(tmp, tmplen, "%s.XXXXXX", path) >= tmplen) {
    snprintf(msg, msglen, "name too long");
    return 1;
  }
  *fd = mkostemp(tmp, O_CLOEXEC);
  if (*fd < 0) {
    snprintf(msg, msglen, "%s", strerror(errno));
    return 1;
  }
  /* mkstemp makes 0600; the sidecar is for the same readers as the output (umask applies) */
  mode_t um = umask(0);
  umask(um);
  (void)fchmod(*fd, 0666 & ~um);
  msg[0] = '\0';
  return 0;
}

int nuno_tmp_write(int fd, const char *buf, int n)
{
  while (n > 0) {
    ssize_t w = write(fd, buf, (size_t)n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return 1;
    }
    buf += w;
    n -= (int)w;
  }
  return 0;
}

int nuno_tmp_commit(int fd, const char *tmp, const char *path, int ok, char *msg, int msglen)
{
  msg[0] = '\0';
  if (close(fd) != 0 && ok) {
    snprintf(msg, msglen, "%s", strerror(errno));
    ok = 0;
  }
  if (ok && nuno_rename(tmp, path, msg, msglen) == 0) return 0;
  unlink(tmp);
  return 1;
}

/* A private scratch directory: template ends in XXXXXX, replaced in place
 * (mkdtemp: a new directory of mode 0700 that no one else made). 0 on
 * success, else 1 with the cause in msg. */
int nuno_mkdtemp(char *templ, char *msg, int msglen)
{
  if (!mkdtemp(templ)) {
    snprintf(msg, msglen, "%s", strerror(errno));
    return 1;
  }
  msg[0] = '\0';
  return 0;
}

#include <ftw.h>
static int rm_entry(const char *p, const struct stat *s, int flag, struct FTW *f)
{
  (void)s;
  (void)f;
  if (flag == FTW_DP) rmdir(p);
  else unlink(p);
  return 0; /* best effort: go on with the rest */
}

/* Remove the tree of a directory that this run made with nuno_mkdtemp
 * (and only such a one): depth first, symbolic links removed as links,
 * never followed (FTW_PHYS), never leaving the file system (FTW_MOUNT). */
void nuno_remove_scratch(const char *dir)
{
  struct stat s;
  if (lstat(dir, &s) != 0 || !S_ISDIR(s.st_mode)) return;
  nftw(dir, rm_entry, 16, FTW_DEPTH | FTW_PHYS | FTW_MOUNT);
}

/* Files this run made and removes if it ends in an error before they
 * became results (a failed start leaves nothing it did not find): the
 * registry of module safe_files, on the rank that made them. kind 1: a
 * file (removed if still a regular file), 2: a scratch directory
 * (nuno_remove_scratch), 3: a lock (nuno_lock_release, fd). */
#define NUNO_CLEANUP_MAX 8
static struct {
  char path[PATH_MAX];
  int  kind, fd;
} cleanup[NUNO_CLEANUP_MAX];
static int n_cleanup = 0;

void nuno_cleanup_add(const char *path, int kind, int fd)
{
  for (int i = 0; i < n_cleanup; i++)
    if (!strcmp(cleanup[i].path, path)) {
      cleanup[i].kind = kind;
      cleanup[i].fd   = fd;
      return;
    }
  if (n_cleanup == NUNO_CLEANUP_MAX || strlen(path) >= PATH_MAX) return;
  snprintf(cleanup[n_cleanup].path, PATH_MAX, "%s", path);
  cleanup[n_cleanup].kind = kind;
  cleanup[n_cleanup].fd   = fd;
  n_cleanup++;
}

void nuno_cleanup_drop(const char *path)
{
  for (int i = 0; i < n_cleanup; i++)
    if (!strcmp(cleanup[i].path, path)) {
      cleanup[i] = cleanup[--n_cleanup];
      return;
    }
}

/* Remove what is registered, last first (the lock after the files it guards). */
void nuno_cleanup_run(void)
{
  char msg[64];
  while (n_cleanup > 0) {
    n_cleanup--;
    if (cleanup[n_cleanup].kind == 1) nuno_remove_file(cleanup[n_cleanup].path, msg, sizeof(msg));
    else if (cleanup[n_cleanup].kind == 2) nuno_remove_scratch(cleanup[n_cleanup].path);
    else if (cleanup[n_cleanup].kind == 3) nuno_lock_release(cleanup[n_cleanup].path, cleanup[n_cleanup].fd);
  }
}
