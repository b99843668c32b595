"""png.py — a small PNG reader for the tests, Python standard library only.

read(path) -> (width, height, channels, bits, rows): rows[y][x*channels + c]
as ints (0..255 or 0..65535). Handles what sylva writes: non-interlaced,
8- or 16-bit grey, grey+alpha, RGB, RGBA, and indexed (1, 2, 4 or 8 bits;
given back as RGBA when it has tRNS, else RGB: what the same texels would
have been written as unindexed). Keep the images small (a 2048²
RGBA atlas takes many seconds here): the tests bake with a small max_atlas.
"""
import struct
import zlib

_CHANNELS = {0: 1, 4: 2, 2: 3, 6: 4}


def read(path):
    data = open(path, 'rb').read()
    if data[:8] != b'\x89PNG\r\n\x1a\n':
        raise ValueError('%s: not a PNG' % path)
    pos, idat, hdr, plte, trns = 8, [], None, b'', b''
    while pos < len(data):
        n, kind = struct.unpack_from('>I4s', data, pos)
        body = data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b'IHDR':
            hdr = struct.unpack('>IIBBBBB', body)
        elif kind == b'IDAT':
            idat.append(body)
        elif kind == b'PLTE':
            plte = body
        elif kind == b'tRNS':
            trns = body
        elif kind == b'IEND':
            break
    w, h, bits, ctype, _, _, interlace = hdr
    indexed = ctype == 3 and bits in (1, 2, 4, 8) and len(plte) >= 3
    if not (indexed or (ctype in _CHANNELS and bits in (8, 16))) or interlace:
        raise ValueError('%s: colour type %d, %d bits, interlace %d not handled'
                         % (path, ctype, bits, interlace))
    ch = 1 if indexed else _CHANNELS[ctype]
    bpp = max(1, ch * bits // 8)
    stride = (w * ch * bits + 7) // 8
    raw = zlib.decompress(b''.join(idat))
    prev = bytearray(stride)
    rows = []
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        if f == 1:
            for i in range(bpp, stride):
                line[i] = (line[i] + line[i - bpp]) & 255
        elif f == 2:
            for i in range(stride):
                line[i] = (line[i] + prev[i]) & 255
        elif f == 3:
            for i in range(stride):
                a = line[i - bpp] if i >= bpp else 0
                line[i] = (line[i] + ((a + prev[i]) >> 1)) & 255
        elif f == 4:
            for i in range(stride):
                a = line[i - bpp] if i >= bpp else 0
                b = prev[i]
                c = prev[i - bpp] if i >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pr = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pr) & 255
        elif f != 0:
            raise ValueError('%s: bad filter %d in row %d' % (path, f, y))
        prev = line
        if indexed:
            per = 8 // bits
            idx = [(line[x // per] >> (8 - bits * (x % per + 1))) & ((1 << bits) - 1)
                   for x in range(w)]
            out = []
            for i in idx:
                out += list(plte[3 * i:3 * i + 3])
                if trns:
                    out.append(trns[i] if i < len(trns) else 255)
            rows.append(out)
        elif bits == 16:
            rows.append(list(struct.unpack('>%dH' % (w * ch), bytes(line))))
        else:
            rows.append(list(line))
    if indexed:
        return w, h, 4 if trns else 3, 8, rows
    return w, h, ch, bits, rows
