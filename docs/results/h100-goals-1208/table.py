import json,sys
runs=[('/tmp/dev1',1),('/tmp/dev2',1),('/tmp/dev2',2)]
scenes=['Sibenik','Sponza','Conference','Armadillo','Dragon']
def load(path):
    out={}
    for r in json.load(open(path))['records']:
        out[(r['scene'],r['tracer'],r['ray_kind'])]=r['perf_mrays_s']
    return out
def rng(v): return f"{min(v):.3f}-{max(v):.3f}" if max(v)-min(v)>=0.0005 else f"{v[0]:.3f}"
print("| scene | primary single / driver, report's tree | shadow best / driver, report's tree | primary single / driver, split leaf 2 | shadow best / driver, split leaf 2 | single primary Mrays/s, report's tree |")
print("|---|---:|---:|---:|---:|---:|")
for sc in scenes:
    cells=[]
    for tree in ['exact','split']:
        p=[];sh=[];best=set();mr=[]
        for d,rd in runs:
            x=load(f"{d}/driver-{tree}-{rd}.json")
            p.append(x[(sc,'gpu-single','primary')]/x[(sc,'driver-rt','primary')])
            s1=x[(sc,'gpu-single','shadow')]; s8=x[(sc,'gpu-cwbvh','shadow')]
            b=max(s1,s8); best.add('single' if s1>=s8 else '8-wide')
            sh.append(b/x[(sc,'driver-rt','shadow')])
            mr.append(x[(sc,'gpu-single','primary')])
        cells.append(rng(p)); cells.append(rng(sh)+" ("+", ".join(sorted(best))+")")
        if tree=='exact': mrs=mr
    print(f"| {sc} | "+" | ".join(cells)+f" | {min(mrs):,.0f}-{max(mrs):,.0f} |")
print()
for mode in ['robust','fast']:
    v=[]
    for d in ['/tmp/dev1','/tmp/dev2']:
        for rd in [1,2]:
            x=load(f"{d}/sibenik-{mode}-{rd}.json"); v.append(x[('Sibenik','gpu-single','primary')])
    print(f"Sibenik sah-split leaf 2, {mode}: "+", ".join(f"{a:,.0f}" for a in v))
