"""Learn to explore mazes on the vector env, in numpy, in about a minute on 2 cores.

    python examples/train_vector_explorer.py [--generations 40] [--figure docs/img/vector_env_coverage.png]

The policy maps the scan, reduced to the nearest range in each of ``SECTORS`` sectors (divided by the
laser's range), through a linear layer and tanh to the action (speed, turn rate). It is trained with
evolution strategies (OpenAI-ES: a policy gradient in parameter space, estimated from antithetic
pairs of perturbed policies): each generation runs ``num_envs / 2`` pairs of perturbations, one env
each, all in one ``MazeVectorEnv``, for one episode of ``--steps`` steps in new random mazes (the
two of a pair in the same maze); an episode's return is its exploration reward (with a small collision
penalty, 0.05 per step, so that touching walls costs less than seeing new ones gains). The figure compares
the wall coverage over an episode of the trained policy and of random actions on held-out mazes.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import mazeslam  # noqa: F401  (registers the environments)

SECTORS = 12


def features(scan: np.ndarray, max_range: float) -> np.ndarray:
    """(E, SECTORS + 1): the nearest return per sector over max_range (no return: 1), and a bias."""
    ranges = np.where(scan > 0, scan, max_range) / max_range
    nearest = ranges.reshape(len(scan), SECTORS, -1).min(axis=2)
    return np.column_stack([nearest, np.ones(len(scan))])


def act(weights: np.ndarray, observation: dict, max_range: float) -> np.ndarray:
    """Actions (E, 2) of the linear-tanh policies ``weights`` (E, SECTORS + 1, 2), one per env."""
    return np.tanh(np.einsum("ef,efa->ea", features(observation["scan"], max_range), weights))


def episodes(envs, policy, seeds) -> tuple[np.ndarray, np.ndarray]:
    """Run one episode per env (mazes from ``seeds``); return the returns (E,) and the coverage
    after each step (T + 1, E). ``policy(observation)`` gives the actions (E, 2)."""
    observation, info = envs.reset(seed=list(seeds))
    returns, coverage = np.zeros(envs.num_envs), [info["coverage"]]
    for _ in range(envs.unwrapped.max_steps):
        observation, reward, terminated, truncated, info = envs.step(policy(observation))
        returns += reward
        coverage.append(info["coverage"])
        if (terminated | truncated).any():
            break  # every episode lasts max_steps unless its maze was explored: stop at the first end
    return returns, np.array(coverage)


def train(envs, generations: int, sigma: float = 0.5, learning_rate: float = 0.2, seed: int = 0):
    """OpenAI-ES on the linear policy; returns its weights and the mean return per generation."""
    rng = np.random.default_rng(seed)
    max_range = envs.unwrapped.config.laser.max_range
    pairs = envs.num_envs // 2
    weights = np.zeros((SECTORS + 1, 2))
    history = []
    for generation in range(generations):
        noise = rng.standard_normal((pairs, SECTORS + 1, 2))
        population = weights + sigma * np.concatenate([noise, -noise])  # env k and k + pairs: a pair
        maze_seeds = 1000 * (generation + 1) + np.tile(np.arange(pairs), 2)

        def policy(observation, population=population):
            return act(population, observation, max_range)

        returns, _ = episodes(envs, policy, maze_seeds)
        advantage = returns[:pairs] - returns[pairs:]
        weights = weights + learning_rate / (2 * pairs * sigma) * np.einsum(
            "p,pfa->fa", advantage / (advantage.std() + 1e-8), noise
        )
        history.append(returns.mean())
        print(f"generation {generation:3d}: mean return {returns.mean():7.2f}", flush=True)
    return weights, np.array(history)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--generations", type=int, default=40)
    parser.add_argument("--num-envs", type=int, default=64)
    parser.add_argument("--steps", type=int, default=200, help="steps per episode (0.1 s each)")
    parser.add_argument("--size", type=int, default=6, help="maze rows and columns")
    parser.add_argument("--figure", default="vector_env_coverage.png")
    args = parser.parse_args()
    envs = gym.make_vec(
        "mazeslam/Maze-v0",
        num_envs=args.num_envs,
        vectorization_mode="vector_entry_point",
        rows=args.size,
        cols=args.size,
        max_steps=args.steps,
        collision_penalty=0.05,
    )
    began = time.perf_counter()
    weights, history = train(envs, args.generations)
    print(f"trained in {time.perf_counter() - began:.0f} s")
    max_range = envs.unwrapped.config.laser.max_range
    held_out = np.arange(args.num_envs) + 10**6
    trained_returns, trained = episodes(
        envs,
        lambda observation: act(np.broadcast_to(weights, (args.num_envs, *weights.shape)), observation, max_range),
        held_out,
    )
    envs.action_space.seed(0)
    random_returns, random = episodes(envs, lambda observation: envs.action_space.sample(), held_out)
    print(
        f"held-out mazes: return {trained_returns.mean():.1f} trained, {random_returns.mean():.1f} random; "
        f"final wall coverage {trained[-1].mean():.1%} trained, {random[-1].mean():.1%} random"
    )
    plot(trained, random, history, args)


def plot(trained: np.ndarray, random: np.ndarray, history: np.ndarray, args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (curve, learning) = plt.subplots(1, 2, figsize=(10, 4))
    for coverage, label in ((trained, "trained policy (ES)"), (random, "random actions")):
        seconds = np.arange(len(coverage)) * 0.1
        mean, spread = 100 * coverage.mean(axis=1), 100 * coverage.std(axis=1)
        curve.plot(seconds, mean, label=label)
        curve.fill_between(seconds, mean - spread, mean + spread, alpha=0.2)
    curve.set(
        xlabel="simulated time (s)",
        ylabel="wall surface seen (%)",
        title=f"Coverage on {args.num_envs} held-out {args.size}x{args.size} mazes (mean ± sd)",
    )
    curve.legend()
    learning.plot(np.arange(1, len(history) + 1), history, label="mean return of the perturbed policies")
    learning.set(xlabel="generation", ylabel="return (reward units)", title="Training (ES, one episode per env)")
    learning.legend()
    figure.tight_layout()
    figure.savefig(args.figure, dpi=120)
    print(f"figure: {args.figure}")


if __name__ == "__main__":
    main()
