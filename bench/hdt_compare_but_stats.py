#!/usr/bin/env python3
"""Two .hdt files: SAME when every section is byte-identical except the statistics
section's timings (5 f64 at payload offset 80), peak memory (2 u64 at 120) and its CRC."""
import struct, sys
def sections(path):
    b = open(path, "rb").read()
    out, at = [("file header", b[:12])], 12
    while at < len(b):
        sid, enc, stored, raw, crc = struct.unpack_from("<IIQQI", b, at)
        payload = b[at + 28: at + 28 + stored]
        if sid == 2:
            p = bytearray(payload); p[80:136] = bytes(56)
            out.append((sid, b[at:at + 24], bytes(p)))
        else:
            out.append((sid, b[at:at + 28], payload))
        at += 28 + stored
        if sid == 6: break
    return out, len(b)
a, la = sections(sys.argv[1]); b, lb = sections(sys.argv[2])
ids = [s[0] for s in a]
diff = [s[0] for s, t in zip(a, b) if s != t]
print("%s sections %s sizes %d %d" % ("SAME" if la == lb and len(a) == len(b) and not diff else "DIFFER " + str(diff), ids, la, lb))
