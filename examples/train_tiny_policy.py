"""Train a tiny policy on mazeslam/Maze-v0 for a few thousand steps - if stable-baselines3 is installed.

mazeslam does not depend on a reinforcement-learning library; this example runs only where one is:

    pip install stable-baselines3
    python examples/train_tiny_policy.py [--steps 5000]

It trains PPO with a small multi-input network on 3 x 3 mazes and compares the exploration reward of
the trained policy with a random one over a few episodes.
"""

import argparse
import sys

import gymnasium as gym
import numpy as np

import mazeslam  # noqa: F401  (registers the environments)


def mean_return(env, act, episodes=3, seed=100):
    totals = []
    for episode in range(episodes):
        observation, _ = env.reset(seed=seed + episode)
        total, done = 0.0, False
        while not done:
            observation, reward, terminated, truncated, _ = env.step(act(observation))
            total += reward
            done = terminated or truncated
        totals.append(total)
    return float(np.mean(totals))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=5000)
    args = parser.parse_args()
    try:
        from stable_baselines3 import PPO
    except ImportError:
        print("stable-baselines3 is not installed: pip install stable-baselines3, then run this again.")
        return 0
    env = gym.make("mazeslam/Maze-v0", rows=3, cols=3, max_episode_steps=300)
    model = PPO(
        "MultiInputPolicy", env, n_steps=512, batch_size=64, policy_kwargs={"net_arch": [32, 32]}, seed=0, verbose=0
    )
    model.learn(total_timesteps=args.steps)
    trained = mean_return(env, lambda observation: model.predict(observation, deterministic=True)[0])
    random = mean_return(env, lambda observation: env.action_space.sample())
    print(f"after {args.steps} steps: mean return {trained:.1f} (random policy: {random:.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
