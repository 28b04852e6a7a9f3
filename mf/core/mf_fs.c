#define _POSIX_C_SOURCE 200809L
#include "mf_fs.h"

#include <ctype.h>
#include <dirent.h>
#include <limits.h>
#include <errno.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "mf_error.h"

static atomic_uint g_tmp_counter;

int mf_tmp_path(const char *path, char *out, size_t cap) {
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    size_t dirlen = (size_t)(base - path);
    size_t stemlen = dot ? (size_t)(dot - base) : strlen(base);
    unsigned n = atomic_fetch_add(&g_tmp_counter, 1u);
    int w = snprintf(out, cap, "%.*s.%.*s.tmp%ld_%u%s", (int)dirlen, path, (int)stemlen, base,
                     (long)getpid(), n, dot ? dot : "");
    if (w < 0 || (size_t)w >= cap) return mf_fail(MF_EARG, "%s: path too long", path);
    return MF_OK;
}

int mf_is_tmp_name(const char *name, long *pid) {
    if (name[0] != '.') return 0;
    /* the stem may itself hold ".tmp": try every occurrence */
    for (const char *t = strstr(name + 1, ".tmp"); t; t = strstr(t + 1, ".tmp")) {
        if (t == name + 1) continue; /* empty stem: mf_tmp_path never writes it */
        const char *p = t + 4, *d0 = p;
        while (isdigit((unsigned char)*p)) ++p;
        if (p == d0 || *p != '_') continue;
        const char *n0 = ++p;
        while (isdigit((unsigned char)*p)) ++p;
        if (p == n0 || (*p != '\0' && *p != '.')) continue;
        if (*p == '.' && strchr(p + 1, '.')) continue; /* one extension at most */
        if (pid) *pid = strtol(d0, NULL, 10);
        return 1;
    }
    return 0;
}

int mf_remove_stale_tmp(const char *dir, int depth, int *removed) {
    DIR *d = opendir(dir);
    if (!d) return errno == ENOENT || errno == ENOTDIR ? MF_OK : mf_fail(MF_EIO, "%s: cannot list: %s", dir, strerror(errno));
    int rc = MF_OK;
    for (struct dirent *e; rc == MF_OK && (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        char p[MF_PATH_MAX];
        if (mf_path_join(p, sizeof p, dir, e->d_name)) continue;
        struct stat st;
        if (lstat(p, &st) != 0) continue;
        if (S_ISDIR(st.st_mode)) {
            if (depth > 0) rc = mf_remove_stale_tmp(p, depth - 1, removed);
            continue;
        }
        long pid = 0;
        if (!S_ISREG(st.st_mode) || !mf_is_tmp_name(e->d_name, &pid)) continue;
        if (pid == (long)getpid() || (pid > 0 && (kill((pid_t)pid, 0) == 0 || errno == EPERM))) continue; /* live */
        if (remove(p) != 0) rc = mf_fail(MF_EIO, "%s: cannot remove a stale temporary file: %s", p, strerror(errno));
        else if (removed) ++*removed;
    }
    closedir(d);
    return rc;
}

int mf_remove_tree(const char *path) {
    struct stat st;
    if (lstat(path, &st) != 0) return errno == ENOENT ? MF_OK : mf_fail(MF_EIO, "%s: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode)) {
        DIR *d = opendir(path);
        if (!d) return mf_fail(MF_EIO, "%s: cannot open the folder: %s", path, strerror(errno));
        int rc = MF_OK;
        struct dirent *e;
        while (!rc && (e = readdir(d))) {
            if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
            char sub[MF_PATH_MAX];
            rc = mf_path_join(sub, sizeof sub, path, e->d_name);
            if (!rc) rc = mf_remove_tree(sub);
        }
        closedir(d);
        if (rc) return rc;
    }
    if (remove(path) != 0) return mf_fail(MF_EIO, "%s: cannot remove: %s", path, strerror(errno));
    return MF_OK;
}

int mf_commit_file(const char *tmp, const char *path) {
    if (rename(tmp, path) != 0) {
        int e = errno;
        remove(tmp);
        return mf_fail(MF_EIO, "%s: cannot rename from %s: %s", path, tmp, strerror(e));
    }
    return MF_OK;
}

void mf_discard_file(const char *tmp) { remove(tmp); }

int mf_mkdirs(const char *dir) {
    char buf[MF_PATH_MAX];
    size_t n = strlen(dir);
    if (n == 0) return MF_OK;
    if (n >= sizeof buf) return mf_fail(MF_EARG, "%s: path too long", dir);
    memcpy(buf, dir, n + 1);
    for (size_t i = 1; i <= n; ++i) {
        if (buf[i] == '/' || buf[i] == '\0') {
            char c = buf[i];
            buf[i] = '\0';
            if (mkdir(buf, 0777) != 0 && errno != EEXIST)
                return mf_fail(MF_EIO, "%s: cannot create directory: %s", buf, strerror(errno));
            buf[i] = c;
        }
    }
    return MF_OK;
}

int mf_mkdirs_for(const char *path) {
    const char *slash = strrchr(path, '/');
    if (!slash) return MF_OK;
    char buf[MF_PATH_MAX];
    size_t n = (size_t)(slash - path);
    if (n >= sizeof buf) return mf_fail(MF_EARG, "%s: path too long", path);
    memcpy(buf, path, n);
    buf[n] = '\0';
    return mf_mkdirs(buf);
}

int mf_file_exists(const char *path) {
    struct stat st;
    return stat(path, &st) == 0;
}

static int check_stat(const char *path, const struct stat *st, unsigned long long *size) {
    if (S_ISDIR(st->st_mode)) return mf_fail(MF_EIO, "%s: is a directory, expected a file", path);
    if (!S_ISREG(st->st_mode)) return mf_fail(MF_EIO, "%s: is not a regular file", path);
    if (size) *size = (unsigned long long)st->st_size;
    return MF_OK;
}

int mf_input_file(const char *path, unsigned long long *size) {
    struct stat st;
    if (stat(path, &st) != 0) {
        if (errno == ENOENT) return mf_fail(MF_EIO, "%s: no such file", path);
        return mf_fail(MF_EIO, "%s: cannot open: %s", path, strerror(errno));
    }
    return check_stat(path, &st, size);
}

int mf_read_file(const char *path, char **data, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return mf_fail(MF_EIO, "%s: cannot open: %s", path, strerror(errno));
    /* a directory opens fine on Linux and "seeks" to LONG_MAX: check what was opened */
    struct stat st;
    unsigned long long usz = 0;
    int rc = fstat(fileno(f), &st) != 0 ? mf_fail(MF_EIO, "%s: cannot stat: %s", path, strerror(errno)) : check_stat(path, &st, &usz);
    if (rc) { fclose(f); return rc; }
    if (usz > (unsigned long long)LONG_MAX - 1) { fclose(f); return mf_fail(MF_EIO, "%s: too large (%llu bytes)", path, usz); }
    long sz = (long)usz;
    char *buf = malloc((size_t)sz + 1);
    if (!buf) { fclose(f); return mf_fail(MF_ENOMEM, "%s: out of memory (%ld bytes)", path, sz); }
    size_t got = fread(buf, 1, (size_t)sz, f);
    fclose(f);
    if (got != (size_t)sz) { free(buf); return mf_fail(MF_EIO, "%s: short read", path); }
    buf[sz] = '\0';
    *data = buf;
    if (len) *len = (size_t)sz;
    return MF_OK;
}

int mf_write_file(const char *path, const void *data, size_t len) {
    char tmp[MF_PATH_MAX];
    int rc = mf_tmp_path(path, tmp, sizeof tmp);
    if (rc) return rc;
    FILE *f = fopen(tmp, "wb");
    if (!f) return mf_fail(MF_EIO, "%s: cannot write: %s", path, strerror(errno));
    size_t put = fwrite(data, 1, len, f);
    int bad = fclose(f) != 0 || put != len;
    if (bad) { mf_discard_file(tmp); return mf_fail(MF_EIO, "%s: write failed", path); }
    return mf_commit_file(tmp, path);
}

int mf_find_duplicate_name(const char *first, size_t stride, int n, int *i, int *j) {
    for (int b = 1; b < n; ++b)
        for (int a = 0; a < b; ++a)
            if (!strcmp(first + (size_t)a * stride, first + (size_t)b * stride)) {
                *i = a, *j = b;
                return 1;
            }
    return 0;
}

int mf_path_join(char *out, size_t cap, const char *a, const char *b) {
    size_t la = strlen(a);
    int w = (la == 0 || a[la - 1] == '/') ? snprintf(out, cap, "%s%s", a, b) : snprintf(out, cap, "%s/%s", a, b);
    if (w < 0 || (size_t)w >= cap) return mf_fail(MF_EARG, "%s/%s: path too long", a, b);
    return MF_OK;
}

void mf_path_ext(const char *path, char *ext, size_t cap) {
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash : path, '.');
    size_t i = 0;
    if (dot)
        for (const char *p = dot + 1; *p && i + 1 < cap; ++p) ext[i++] = (char)tolower((unsigned char)*p);
    ext[i] = '\0';
}
