# usage: rate.sh ROUNDS BIN... : sah-binned vs Embree medium, build-repeat 5, the build-rate scenes in order
S=/work/shared/scenes
SC=${SC:-$S/sibenik/sibenik_geom_75284.ply,$S/dabrovic_sponza/sponza.obj,$S/conference/conference_geom.ply,$S/stanford/armadillo_decimated_99976.obj,$S/stanford/dragon_vrip_res2.ply,gen:terrain:1M}
R=$1; shift
for r in $(seq 1 $R); do for b in "$@"; do
  $TS $b bench --scenes $SC --device cpu --width 16 --height 16 --repeat 1 --no-driver-rt --builder sah-binned --build-repeat 5 --out /tmp/rate.json >/dev/null 2>&1
  python3 -c "
import json
d=json.load(open('/tmp/rate.json')); rp={}; em={}; order=[]
for r in d['records']:
  s=r['scene'].split('/')[-1][:10]
  if s not in order: order.append(s)
  if r['tracer']=='embree':
    if r.get('embree_quality')=='medium': em.setdefault(s, r['t_b_s'])
  else: rp.setdefault(s, r['t_b_s'])
print('$b'[-8:], ' '.join('%s %.1f/%.1f=%.2f'%(s, rp[s]*1e3, em[s]*1e3, em[s]/rp[s]) for s in order if s in rp and s in em))
"
done; done
S=/work/shared/scenes
for b in "$@"; do for SC in gen:terrain:10k,$S/sibenik/sibenik_geom_75284.ply $S/dabrovic_sponza/sponza.obj,$S/sibenik/sibenik_geom_75284.ply; do $TS $b bench --scenes $SC --device cpu --width 16 --height 16 --repeat 1 --no-driver-rt --builder sah-binned --build-repeat 7 --out /tmp/tab.json >/dev/null 2>&1; python3 -c "
import json
d=json.load(open('/tmp/tab.json'))
seen=set()
for r in d['records']:
  k=(r['scene'][-12:], r['tracer']=='embree')
  if k in seen or (r['tracer']=='embree' and r.get('embree_quality')!='medium'): continue
  seen.add(k); print('$b'[-8:], r['scene'][-10:], '${SC:0:8}', r['tracer'][:6], [round(x*1000,1) for x in r.get('t_b_runs_s',[])], round(r['t_b_s']*1000,1))
" ; done; done
