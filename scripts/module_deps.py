#!/usr/bin/env python3
"""Module dependency edges of a crate's src/ from its path references (crate::, super::, child::),
and the cycles among them. Usage: deps.py SRC_DIR [PREFIX_FILTER]"""
import os, re, sys
src = sys.argv[1]
mods = {}
for root, _, files in os.walk(src):
    for f in files:
        if not f.endswith('.rs'): continue
        p = os.path.relpath(os.path.join(root, f), src)[:-3]
        if p.endswith('/mod'): p = p[:-4]
        if p in ('lib', 'main'): p = ''  # crate root
        mods[p] = os.path.join(root, f)
def resolve(parts):
    # longest prefix of parts that is a module
    for k in range(len(parts), -1, -1):
        m = '/'.join(parts[:k])
        if m in mods: return m
    return ''
def strip_tests(text):
    i = text.find('#[cfg(test)]')
    return text if i < 0 else text[:i]
edges = set()
for m, path in mods.items():
    text = strip_tests(open(path).read())
    text = re.sub(r'//[^\n]*', '', text)
    # expand use groups: use X::{a, b::c}; (one level)
    def expand(mt):
        pre, body = mt.group(1), mt.group(2)
        return ' '.join(f'{pre}::{x.strip()}' for x in body.split(',') if x.strip())
    for _ in range(3):
        text = re.sub(r'((?:crate|super|self|\w+)(?:::\w+)*)::\{([^{}]*)\}', expand, text)
    here = m.split('/') if m else []
    children = {c.split('/')[-1] for c in mods if c and '/'.join(c.split('/')[:-1]) == m}
    for mt in re.finditer(r'\b(crate|super|self|\w+)((?:::\w+)+)', text):
        head, rest = mt.group(1), mt.group(2).split('::')[1:]
        if head == 'crate': parts = rest
        elif head == 'super':
            base = here[:-1]
            while rest and rest[0] == 'super': base = base[:-1]; rest = rest[1:]
            parts = base + rest
        elif head == 'self': parts = here + rest
        elif head in children: parts = here + [head] + rest
        else: continue
        t = resolve(parts)
        if t != m and t != '':
            edges.add((m or '<root>', t))
flt = sys.argv[2] if len(sys.argv) > 2 else ''
E = sorted(e for e in edges if e[0].startswith(flt) or e[1].startswith(flt))
for a, b in E: print(f'  {a} -> {b}')
# cycles: SCCs
adj = {}
for a, b in edges: adj.setdefault(a, []).append(b)
idx, low, st, on, out, n = {}, {}, [], set(), [], [0]
def sc(v):
    idx[v] = low[v] = n[0]; n[0] += 1; st.append(v); on.add(v)
    for w in adj.get(v, []):
        if w not in idx: sc(w); low[v] = min(low[v], low[w])
        elif w in on: low[v] = min(low[v], idx[w])
    if low[v] == idx[v]:
        comp = []
        while True:
            w = st.pop(); on.discard(w); comp.append(w)
            if w == v: break
        if len(comp) > 1: out.append(sorted(comp))
sys.setrecursionlimit(10000)
for v in list(adj):
    if v not in idx: sc(v)
print('cycles (strongly connected groups):', out if out else 'none')
