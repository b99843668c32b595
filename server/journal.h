/* journal.h — append-only journal of accepted jobs (crash-safe).
 *
 * On disk, a sequence of records:
 *   "SVJ1" | u32 little-endian payload length | first 16 bytes of SHA-256(payload)
 *   | payload (one JSON object, not NUL-terminated)
 * A record is durable once svd_journal_append returns (write + fdatasync).
 * At open, every intact record is replayed in order. A torn last record
 * (crash mid-append: short header or payload past end of file) is cut off
 * (ftruncate + fsync). A damaged record in the middle (checksum mismatch or
 * garbage before the next "SVJ1") is copied to "<path>.corrupt-<offset>",
 * counted and skipped; replay resumes at the next intact record.
 * The payload format is the caller's (jobs.c writes {"op":...}).
 */
#ifndef SVD_JOURNAL_H
#define SVD_JOURNAL_H

#include <stddef.h>
#include <stdint.h>

#include "sv.h"

#define SVD_JOURNAL_MAX_RECORD (1u << 20) /* payload bytes */

typedef struct svd_journal svd_journal;

typedef struct svd_journal_stats {
    uint64_t records;    /* intact records replayed */
    uint64_t torn_bytes; /* bytes cut from the end */
    uint64_t corrupt;    /* damaged records quarantined */
} svd_journal_stats;

/* Called once per intact record at open, in file order. */
typedef void (*svd_journal_replay_fn)(void *user, const char *payload, size_t size);

/* Opens (creating if needed) the journal at path, replays it through fn, and
 * repairs its tail. stats may be NULL. Returns NULL with err set on I/O error. */
svd_journal *svd_journal_open(const char *path, svd_journal_replay_fn fn, void *user,
                              svd_journal_stats *stats, sv_error *err);

/* Appends one record and makes it durable before returning. Thread-safe.
 * SV_ERR_LIMIT if size > SVD_JOURNAL_MAX_RECORD, SV_ERR_IO on write/fsync
 * failure (the file is truncated back so no torn record stays behind). */
sv_status svd_journal_append(svd_journal *j, const char *payload, size_t size, sv_error *err);

/* Replaces the journal's content with exactly these records (compaction):
 * written to a temp file, fsynced, renamed over the journal, directory fsynced.
 * Thread-safe. A failure before the rename leaves the old journal in use and
 * no temp file; after it (the directory fsync) the new journal is in use and
 * the error is still returned. Appends always go to the file at the path. */
sv_status svd_journal_rewrite(svd_journal *j, const char *const *payloads, const size_t *sizes,
                              size_t count, sv_error *err);

/* Closes the journal. NULL is a no-op. */
void svd_journal_close(svd_journal *j);

/* fsyncs the directory that holds path (after a rename or create in it). */
sv_status svd_fsync_parent(const char *path, sv_error *err);

#endif
