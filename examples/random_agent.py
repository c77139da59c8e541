"""A random agent in mazeslam/Maze-v0: how much of the maze does chance explore?

    python examples/random_agent.py [--steps 2000] [--seed 0]
"""

import argparse

import gymnasium as gym

import mazeslam  # noqa: F401  (registers the environments)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    env = gym.make("mazeslam/Maze-v0", max_steps=args.steps)
    env.action_space.seed(args.seed)
    observation, info = env.reset(seed=args.seed)
    total, collisions, steps_taken = 0.0, 0, 0
    for _ in range(args.steps):
        observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
        steps_taken += 1
        total += reward
        collisions += info["collision"]
        if terminated or truncated:
            break
    print(f"random agent: {steps_taken} steps, reward {total:.1f}, cells visited {info['visited']:.0%}, "
          f"walls seen {info['coverage']:.0%}, steps touching a wall {collisions}")


if __name__ == "__main__":
    main()
