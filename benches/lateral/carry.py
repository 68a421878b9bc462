import struct, sys
items=[24,24,12,16,32, 8,64,128,4,64,128,8,16]
for p in sys.argv[1:]:
    b=open(p,'rb').read()
    assert b[0] & 1 == 1, p
    at=1
    counts=[]
    for ib in items:
        n=struct.unpack_from('<Q',b,at)[0]; counts.append(n)
        at+=8+n*ib
        assert at<=len(b),(p,counts)
    print(p, counts, at, len(b))
    nb=b[:at]+struct.pack('<Q',0)+struct.pack('<Q',0)+b[at:]
    open(p,'wb').write(nb)
