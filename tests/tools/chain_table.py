#!/usr/bin/env python3
"""chain_table.py REPORT.json [TITLE] — prints the Markdown table of one bake's
LOD chain (kept and skipped levels, finest first) as docs/lod.md shows it:
triangles, 1 − IoU at each measured size, own limit, switch distance, and
whether the level is in the chain (with the planner's reason when it is not).
Used to regenerate the "Measured chains" section of docs/lod.md."""
import json
import sys


def main():
    r = json.load(open(sys.argv[1]))
    c = r['lod_chain']
    rows = []
    for l in r['lods']:
        rows.append((l['name'], l['source'], l['triangles'], l.get('accuracy', []),
                     l['switch_pixels'], l.get('switch_distance'), 'yes'))
    for s in c['skipped']:
        if 'triangles' not in s:
            continue
        rows.append((s['name'], '', s['triangles'], s.get('accuracy', []),
                     s.get('own_limit_pixels', 0), None, 'skipped: ' + s['reason']))
    # chain order: finest first, as the planner lists them
    order = {n: i for i, n in enumerate(
        ['full', 'stochastic50', 'stochastic25', 'stochastic10'])}
    def key(row):
        n = row[0]
        if n in order:
            return (0, order[n])
        if n == 'crossed':
            return (3, 0)
        digits = ''.join(ch for ch in n if ch.isdigit())
        return (1, -int(digits) if digits and not n.startswith('lod') else int(digits or 0))
    rows.sort(key=key)
    sizes = [a['pixels'] for a in rows[0][3]] if rows[0][3] else []
    for row in rows:
        if row[3]:
            sizes = [a['pixels'] for a in row[3]]
            break
    print('Tolerance %g (1 − IoU) at %g px, scaled as 1/size.' %
          (c['tolerance'], c.get('tolerance_pixels', 0)))
    print()
    print('| LOD | triangles | ' + ' | '.join('1−IoU @%d px' % s for s in sizes) +
          ' | own limit (px) | switch distance (m) | in the chain |')
    print('| --- | ---: | ' + ' | '.join('---:' for _ in sizes) + ' | ---: | ---: | --- |')
    for name, src, tris, acc, px, dist, status in rows:
        errs = {a['pixels']: 1 - a['iou_mean'] for a in acc}
        cells = ['%.3f' % errs[s] if s in errs else '' for s in sizes]
        print('| %s | %d | %s | %.4g | %s | %s |' % (
            name, tris, ' | '.join(cells), px, '%.4g' % dist if dist else '', status))


if __name__ == '__main__':
    main()
