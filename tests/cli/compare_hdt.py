"""compare_hdt.py A.hdt B.hdt: exits 1 unless the two .hdt files hold the same
volume: every section byte for byte, except in the statistics section the
run's own measurements (phase times, peak memory, threads), which differ
between any two runs. Prints the first difference."""
import sys

MEASURED = (range(80, 136 + 4),)  # statistics: times, peak host/device bytes, threads


def sections(path):
    data = open(path, "rb").read()
    out, at = [("header", data[:12])], 12
    while at < len(data):
        sid = int.from_bytes(data[at:at + 4], "little")
        stored = int.from_bytes(data[at + 8:at + 16], "little")
        body = bytearray(data[at + 28:at + 28 + stored])
        header = bytearray(data[at:at + 28])
        if sid == 2:
            for r in MEASURED:
                for i in r:
                    body[i] = 0
            header[24:28] = b"\0\0\0\0"  # its CRC covers the measurements
        out.append((sid, bytes(header) + bytes(body)))
        at += 28 + stored
    return out


a, b = sections(sys.argv[1]), sections(sys.argv[2])
for (ia, sa), (ib, sb) in zip(a, b):
    if ia != ib or sa != sb:
        sys.exit("compare_hdt: section %s differs between %s and %s" % (ia, sys.argv[1], sys.argv[2]))
if len(a) != len(b):
    sys.exit("compare_hdt: section counts differ")
print("compare_hdt: same volume (%d sections)" % (len(a) - 1))
