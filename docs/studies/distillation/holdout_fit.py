"""One-off check quoted in docs/studies/distillation/README.md: how well the student predicts the oracle on held-out episodes.

Usage: PYTHONPATH=. python docs/studies/distillation/holdout_fit.py runs/dagA/data.npz 50 200
(a DAgger data.npz of scripts/studies/distill.py with 30-s episodes = 300 rows each; 1/5 of the episodes held out;
one fresh student per epoch count, obs_history 5).
"""
import sys
import time

import numpy as np
import torch

torch.set_num_threads(1)
sys.path.insert(0, "scripts/studies")  # the DAgger study, run from the repository root
import distill as dg

d=np.load(sys.argv[1]); x,y,it=d['x'],d['y'],d['iteration']
print('labels: frac at -1', np.mean(y<=-0.999), 'at +1', np.mean(y>=0.999), 'mean', y.mean(0), 'std', y.std(0))
# step-to-step label change (noise)
dy=np.diff(y,axis=0); print('rms label step change', np.sqrt(np.mean(dy**2)))
ep=np.arange(len(x))//300; rng=np.random.default_rng(0); te=np.isin(ep, rng.choice(ep.max()+1, (ep.max()+1)//5, replace=False))
for arch_epochs in [int(a) for a in sys.argv[2:]]:
    torch.manual_seed(0); m,_,_,_=dg.make_student(5,None,0); rms=dg._rms(x[~te]); t=time.time()
    l=dg.fit_student(m,x[~te],y[~te],rms,epochs=arch_epochs,lr=1e-3,batch_size=256)
    print(arch_epochs, 'train', dg.action_error(m,x[~te],y[~te],rms), 'test', dg.action_error(m,x[te],y[te],rms), 'per-iter test', [round(dg.action_error(m,x[te&(it==k)],y[te&(it==k)],rms),4) for k in np.unique(it[te])], round(time.time()-t,1),'s')
