#!/usr/bin/env python3
"""hdt_same.py A.hdt B.hdt: whether two .hdt files hold the same volume, byte for
byte, in every section but the statistics (section 2: phase times, peak memory
and thread count differ from run to run). Exit 0 when the same, 1 when not."""
import struct, sys

def sections(path):
    data = open(path, 'rb').read()
    out, at = [(0, data[:12])], 12  # the file header
    while at < len(data):
        sid, enc, stored = struct.unpack_from('<IIQ', data, at)
        out.append((sid, data[at:at + 28 + stored]))
        at += 28 + stored
    return out

a, b = (sections(p) for p in sys.argv[1:3])
same = [s for s in a if s[0] != 2] == [s for s in b if s[0] != 2] and len(a) == len(b)
print('same' if same else 'DIFFERENT', sys.argv[1], sys.argv[2])
sys.exit(0 if same else 1)
