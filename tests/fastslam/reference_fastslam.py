"""A plain FastSLAM 1.0 update that loops over particles in Python: the oracle for the vectorised
filter (tests) and its speed baseline (benchmarks/bench_fastslam.py).

It subclasses ``FastSLAM`` only to share the state arrays, the prediction and the resampling; the
update itself is written per particle, per observation, per landmark, as a textbook reads.
"""

import math

import numpy as np

from mazeslam.fastslam.filter import LOG_TWO_PI, FastSLAM, UpdateReport


class LoopFastSLAM(FastSLAM):
    def update(self, observations, covariances=None, ids=None) -> UpdateReport:
        observations = np.asarray(observations, dtype=float).reshape(-1, 2)
        count = len(observations)
        report = UpdateReport(observations=count)
        if count:
            while (~self.exists).sum(axis=1).min() < count:
                self._grow()
            noise = self.params.inflation * self.params.observation_noise(covariances, count)
            for p in range(self.params.NPARTICLES):
                self._update_particle(p, observations, noise, report)
        report.effective_sample_size = self.effective_sample_size()
        if report.effective_sample_size < self.params.resample_threshold * self.params.NPARTICLES:
            self.resample()
            report.resampled = True
        return report

    def _update_particle(self, p, observations, noise, report):
        x, y, theta = self.poses[p]
        slots = [j for j in range(self.exists.shape[1]) if self.exists[p, j]]
        table = {}  # (k, j) -> (d2, innovation, S, H)
        for k, z in enumerate(observations):
            for j in slots:
                dx, dy = self.means[p, j] - (x, y)
                q = max(dx * dx + dy * dy, 1e-12)
                rho = math.sqrt(q)
                h = np.array([[dx / rho, dy / rho], [-dy / q, dx / q]])
                innovation = np.array([z[0] - rho, math.remainder(z[1] - (math.atan2(dy, dx) - theta), 2 * math.pi)])
                s = h @ self.covariances[p, j] @ h.T + noise[k]
                table[k, j] = (innovation @ np.linalg.solve(s, innovation), innovation, s, h)
        assigned = {}
        free_obs, free_slots = set(range(len(observations))), set(slots)
        while free_obs and free_slots:
            k, j = min(((k, j) for k in free_obs for j in free_slots), key=lambda kj: table[kj][0])
            if table[k, j][0] >= self.params.gate:
                break
            assigned[k] = j
            free_obs.discard(k)
            free_slots.discard(j)
        matched_now = set()
        for k, z in enumerate(observations):
            if k in assigned:
                j = assigned[k]
                d2, innovation, s, h = table[k, j]
                sigma = self.covariances[p, j]
                gain = sigma @ h.T @ np.linalg.inv(s)
                self.means[p, j] += gain @ innovation
                a = np.eye(2) - gain @ h
                self.covariances[p, j] = a @ sigma @ a.T + gain @ noise[k] @ gain.T
                self.log_weights[p] += self.params.likelihood_exponent * (
                    -0.5 * d2 - LOG_TWO_PI - 0.5 * math.log(np.linalg.det(s))
                )
                self.seen[p, j] += 1
                self.missed[p, j] = 0
                matched_now.add(j)
                report.matched += 1
                continue
            nearest = min((table[k, j][0] for j in slots), default=math.inf)
            if nearest < self.params.new_landmark_gate:
                report.ambiguous += 1
                continue
            j = next(j for j in range(self.exists.shape[1]) if not self.exists[p, j])
            rho, bearing = z
            angle = theta + bearing
            self.means[p, j] = (x + rho * math.cos(angle), y + rho * math.sin(angle))
            g = np.array([[math.cos(angle), -rho * math.sin(angle)], [math.sin(angle), rho * math.cos(angle)]])
            self.covariances[p, j] = g @ noise[k] @ g.T
            self.exists[p, j] = True
            self.seen[p, j] = 1
            self.missed[p, j] = 0
            matched_now.add(j)
            self.log_weights[p] += self.params.likelihood_exponent * (
                -0.5 * self.params.new_landmark_gate - LOG_TWO_PI - 0.5 * math.log(np.linalg.det(noise[k]))
            )
            report.new += 1
        for j in range(self.exists.shape[1]):
            if not self.exists[p, j] or j in matched_now or self.seen[p, j] > 1:
                continue
            if math.dist(self.means[p, j], (x, y)) < self.params.view_range:
                self.missed[p, j] += 1
            if self.missed[p, j] >= self.params.tentative_limit:
                self.exists[p, j] = False
                report.removed += 1
