"""Track one Galileo E1-C pilot (BOC(1,1) replica) over the whole 0.5 s real 4 MHz recording.

    python validation/galileo_e1_track.py 27      # PRN; reads ../shared/data/if/ beside the clone

Acquisition (pcps, 4 ms x 4), then 25 open-loop 4 ms prompts whose consecutive products are
matched against CS25_1's (the differential search is blind to the residual Doppler): the
best shift is the secondary-code phase and the product's angle the frequency correction.
Then the engine's scalar loop (eml-envelope DLL d = 0.2 chip, Costas PLL, FLL assist) on
the compiled correlators with the secondary code wiped off. Run on 2026-12-02 (PRN 27):
secondary phase found with a score 3.0x the runner-up, every wiped prompt after the first
25 of one sign (124 intervals), mean |I| / mean |Q| = 14, C/N0 from the prompts 42 dB-Hz.
"""
from gnssframework import registry
import numpy as np, time
from gnssframework import registry
from gnssframework.receiver.engine.channel import Channel
from gnssframework.receiver.engine.closers import ScalarCloser
from gnssframework.receiver.engine.samples import SampleSource
from gnssframework.receiver.channels.correlator import replica_codes
from gnssframework.receiver.frontend.recording import open_recording
from gnssframework.signal.correlators import Correlators
from gnssframework.signal.galileo_e1 import GALILEO_E1C_BOC11 as S
from gnssframework.signal.galileo_codes import GALILEO_E1C_SECONDARY_CS25 as CS
import sys
from pathlib import Path
t0=time.time()
fs=4e6; T=4e-3; d=0.2; prn=int(sys.argv[1])
rec=open_recording(str(next(p for p in (Path(__file__).resolve().parents[2] / 'shared', Path('/work/shared')) if p.is_dir()) / 'data' / 'if' / 'pocketsdr_L1_20211202_084700_4MHz_IQ.bin'), format='ci8', sample_rate_hz=fs, if_hz=0.0, q_sign=-1)
x=np.asarray(rec.read(0, rec.n_samples), np.complex64)
acq=registry.create('acquisition','pcps', noncoherent=4, doppler_max_hz=3500.0, xcorr_margin_db=None)
r=acq.acquire(x[:acq.samples_needed(fs,S)], fs, 0.0, prns=(prn,), signal=S)[0]
src=SampleSource(x, fs, 0.0, replica_codes(S,(prn,)), T, early_late_spacing_chips=d, noise_std=float(np.std(x.real)), subchips_per_chip=S.subchips_per_chip)
cs=np.array(CS,float)
# open loop: 26 prompts, differential secondary-code search (insensitive to the residual Doppler)
ch=Channel.start((1,), r.code_phase_chips, r.doppler_hz, signal=S)
P=[]
for k in range(25):
    ch.run_interval(T); P.append(complex(np.ravel(src.correlate(ch,k).prompt)[0])); ch.steer_frequency(ch.carrier_freq_hz, ch.code_rate_chips_s)
P=np.array(P); diff=P[1:]*P[:-1].conj()
scores=[np.sum(diff*np.roll(cs,-s)[1:]*np.roll(cs,-s)[:-1]) for s in range(25)]
s0=int(np.argmax(np.abs(np.real(scores)) if False else np.abs(scores))); z=scores[s0]
df=np.angle(z)/(2*np.pi*T)
print('acq', r.doppler_hz, r.cn0_dbhz, 'sec phase', s0, 'score', abs(z), sorted(np.abs(scores))[-2], 'df', df)
ch=Channel.start((1,), r.code_phase_chips, r.doppler_hz+df, signal=S)
cl=ScalarCloser(registry.create("channel_filter","scalar")); cl.reset(ch, T, early_late_spacing_chips=d, cn0_dbhz=40.0)
PP=[]; F=[]; C=[]
K=int(len(x)/(fs*T))-1
for k in range(K):
    ch.run_interval(T); c=src.correlate(ch,k); sgn=cs[(k+s0)%25]
    c=Correlators.trusted(c.early*sgn, c.prompt*sgn, c.late*sgn)
    PP.append(complex(np.ravel(c.prompt)[0])); cl.step(ch,c); F.append(float(np.ravel(ch.carrier_freq_hz)[0])); C.append(float(np.ravel(ch.code_phase_chips)[0]))
PP=np.array(PP)
print(K, 'I>0 frac after 25', np.mean(np.sign(PP.real[25:])==np.sign(PP.real[25:].sum())), 'mean|I|/mean|Q|', np.mean(np.abs(PP.real[25:]))/np.mean(np.abs(PP.imag[25:])))
print('freq start/end', F[0], F[-1], 'code rate check', (C[-1]-C[0]), time.time()-t0)
I=PP.real[25:]; Q=PP.imag[25:]
# narrowband-wideband style C/N0 from moments: mean I^2 vs var Q
cn0=10*np.log10((np.mean(I)**2 - 0)/(2*np.var(Q))/T) if False else 10*np.log10(np.mean(I)**2/(2*np.var(Q))/T)
print('cn0 est', cn0)
