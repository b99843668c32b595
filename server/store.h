/* store.h — sylvad's content-addressed store on disk.
 *
 *   ROOT/journal                 accepted jobs (journal.h)
 *   ROOT/tmp/                    uploads and worker outputs in progress; emptied at start
 *   ROOT/shaders/                the daemon's warmed shader cache, read-only (workers.h)
 *   ROOT/quarantine/             objects whose bytes no longer match their SHA-256
 *   ROOT/jobs/KEY/spec.json      the spec as uploaded ("{}" if empty)
 *   ROOT/jobs/KEY/inputs.json    {"mesh":NAME,"files":[...],"objects":{NAME:{"size":N,"sha256":H}}}
 *   ROOT/jobs/KEY/in/NAME        the mesh and its companion files
 *   ROOT/jobs/KEY/result/        artifacts + manifest.json (when done)
 *   ROOT/jobs/KEY/error.json     (when failed)
 *
 * Everything is written under tmp/, fsynced, then renamed into place and the
 * parent directory fsynced, so a crash never leaves a partial object visible.
 * Reads verify SHA-256 against the recorded one (a cache keyed by inode, size
 * and mtime avoids rehashing unchanged files); a mismatch is quarantined.
 */
#ifndef SVD_STORE_H
#define SVD_STORE_H

#include <stdbool.h>
#include <stdint.h>

#include "key.h"
#include "sv.h"

#define SVD_STORE_PATH 1400

typedef struct svd_store svd_store;

/* Opens (creating) the store at root, locks it (one daemon per store: a
 * store another process holds fails naming its pid) and removes stale temp
 * files. Creates no directory that exists (so it opens on a full disk).
 * svd_store_close releases the lock. */
svd_store *svd_store_open(const char *root, sv_error *err);

/* How many stray workers svd_store_open killed: processes of a dead daemon
 * still baking into this store's tmp/. */
int svd_store_stray_workers(const svd_store *s);

/* Closes the store. NULL is a no-op. */
void svd_store_close(svd_store *s);

const char *svd_store_root(const svd_store *s);

/* ROOT/jobs/KEY[/sub] into out (sub may be NULL). */
void svd_store_job_path(const svd_store *s, const char *key, const char *sub,
                        char out[SVD_STORE_PATH]);

/* Creates a fresh directory ROOT/tmp/PREFIX-XXXXXX and returns its path.
 * SV_ERR_LIMIT when the disk is full (ENOSPC), else SV_ERR_IO on failure. */
sv_status svd_store_mktemp(svd_store *s, const char *prefix, char out[SVD_STORE_PATH],
                           sv_error *err);

/* Writes data to dir/name atomically (dir/.name.tmp, fsync, rename, fsync dir). */
sv_status svd_store_write_file(const char *dir, const char *name, const void *data, size_t size,
                               sv_error *err);

/* fsyncs every regular file directly in dir and in its subdirectories (one
 * level), then the directories themselves. */
sv_status svd_store_sync_tree(const char *dir, sv_error *err);

/* Renames src (a directory under tmp/) to ROOT/jobs/KEY[/sub] and fsyncs the
 * parent. SV_ERR_IO if the destination exists or the rename fails. */
sv_status svd_store_install(svd_store *s, const char *src, const char *key, const char *sub,
                            sv_error *err);

/* Removes ROOT/jobs/KEY[/sub] (renamed into tmp/ first, so it vanishes at once). */
void svd_store_remove(svd_store *s, const char *key, const char *sub);

/* Verifies that path has the given size and SHA-256. SV_ERR_INVALID on a
 * mismatch (the caller quarantines), SV_ERR_IO if unreadable. */
sv_status svd_store_verify(svd_store *s, const char *path, uint64_t size, const char *sha256,
                           sv_error *err);

/* Moves path into ROOT/quarantine/ under KEY-NAME-N. */
void svd_store_quarantine(svd_store *s, const char *key, const char *path);

/* Bytes of regular files under dir (recursively). */
uint64_t svd_dir_bytes(const char *dir);

/* Removes a file or a directory tree. Missing is fine. */
void svd_rm_rf(const char *path);

#endif
