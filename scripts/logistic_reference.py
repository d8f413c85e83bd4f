# Reference numbers of tests/test_logistic.c ("small data set"): Debian python3-statsmodels 0.13.5 (Logit, Newton)
# and scipy 1.10.1 (BFGS on the ridge-penalised cost).
import numpy as np, statsmodels.api as sm
from scipy.optimize import minimize
x1=np.array([0.63,0.90,0.78,0.23,0.30,0.87,0.01,0.82,0.80,0.47,0.30,0.28,0.25,0.45,0.50,0.55,1.00,0.79,0.62,0.99,0.22,0.16,0.61,0.04,0.04,0.51,0.47,0.92,0.63,0.51,0.50,0.25,0.01,0.19,0.69,0.20,0.37,0.00,0.83,0.15])
x2=np.array([0.27,0.88,0.51,0.85,0.64,0.74,0.09,0.54,0.51,0.87,0.36,0.60,0.06,0.39,0.32,0.15,0.82,0.38,0.98,0.59,0.61,0.64,0.68,0.15,0.44,0.24,0.40,0.10,0.97,0.22,0.67,0.30,0.87,0.66,0.13,0.85,0.94,0.90,0.57,0.15])
y =np.array([1,0,1,1,0,1,0,1,1,1,1,0,0,1,1,0,1,1,1,1,0,0,1,0,0,1,0,0,1,0,0,0,1,0,1,0,0,1,1,0])
X=np.column_stack([np.ones_like(x1),x1,x2,x1*x1,x1*x2,x2*x2])
r=sm.Logit(y,X).fit(method='newton',tol=1e-14,maxiter=200,disp=0)
print("mle",repr(r.params.tolist())); print("bse",repr(r.bse.tolist())); print("llf",r.llf, r.mle_retvals['converged'])
lam=0.5
def f(t):
    z=X@t; return np.sum(np.logaddexp(0,-z)*y+np.logaddexp(0,z)*(1-y))+0.5*lam*np.sum(t[1:]**2)
o=minimize(f,np.zeros(6),method='BFGS',options={'gtol':1e-12})
print("ridge",repr(o.x.tolist()), o.fun, o.success)
