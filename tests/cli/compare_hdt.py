"""compare_hdt.py [--any-backend] A.hdt B.hdt: exits 1 unless the two .hdt
files hold the same volume: every section byte for byte, except in the
statistics section the run's own measurements (phase times, peak memory,
threads), which differ between any two runs. --any-backend leaves the
statistics section out (it also names the driver that ran: cpu, cuda), for
files of two drivers. Prints the first difference. Reads in bounded chunks,
so it also compares 65536^3 volumes (tens of GB)."""
import sys

STATISTICS = 2
MEASURED = range(80, 136 + 4)  # statistics: times, peak host/device bytes, threads
CHUNK = 64 << 20


def sections(f):
    """(id, offset, header bytes, body length) of every section, header first."""
    f.seek(0, 2)
    size = f.tell()
    f.seek(0)
    out, at = [("header", 0, f.read(12), 0)], 12
    while at < size:
        f.seek(at)
        header = f.read(28)
        sid = int.from_bytes(header[0:4], "little")
        stored = int.from_bytes(header[8:16], "little")
        out.append((sid, at + 28, header, stored))
        at += 28 + stored
    return out


def masked(sid, header, body):
    if sid != STATISTICS:
        return header, body
    header, body = bytearray(header), bytearray(body)
    header[24:28] = b"\0\0\0\0"  # its CRC covers the measurements
    for i in MEASURED:
        if i < len(body):
            body[i] = 0
    return bytes(header), bytes(body)


def same_section(fa, fb, a, b):
    (ia, oa, ha, na), (ib, ob, hb, nb) = a, b
    if ia != ib or na != nb:
        return False
    if ia == STATISTICS:
        fa.seek(oa)
        fb.seek(ob)
        return masked(ia, ha, fa.read(na)) == masked(ib, hb, fb.read(nb))
    if ha != hb:
        return False
    fa.seek(oa)
    fb.seek(ob)
    left = na
    while left > 0:
        n = min(CHUNK, left)
        if fa.read(n) != fb.read(n):
            return False
        left -= n
    return True


args = sys.argv[1:]
any_backend = "--any-backend" in args
args = [x for x in args if x != "--any-backend"]
if len(args) != 2:
    sys.exit("usage: compare_hdt.py [--any-backend] A.hdt B.hdt")
with open(args[0], "rb") as fa, open(args[1], "rb") as fb:
    a, b = sections(fa), sections(fb)
    for sa, sb in zip(a, b):
        if any_backend and sa[0] == STATISTICS and sb[0] == STATISTICS:
            continue
        if not same_section(fa, fb, sa, sb):
            sys.exit("compare_hdt: section %s differs between %s and %s" % (sa[0], args[0], args[1]))
    if len(a) != len(b):
        sys.exit("compare_hdt: section counts differ")
print("compare_hdt: same volume (%d sections)" % (len(a) - 1))
