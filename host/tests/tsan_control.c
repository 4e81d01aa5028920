/* tsan_control — a deliberate data race (two threads increment one int without a lock), for
 * tests/test_host_packaging.py: ThreadSanitizer must report it, or its clean report of
 * host_threads means nothing.
 *
 * Both threads are held alive across the racy loop by two barriers.  Without them the first
 * thread could finish before the second one starts (CI saw exactly 200000 and no report once):
 * ThreadSanitizer's runtime then reuses the finished thread's slot and may lose its accesses,
 * so the control would pass or fail with the scheduler.  The barriers order nothing between the
 * two loops: the increments stay unsynchronised, and both threads exist while they run. */
#include <pthread.h>
#include <stdio.h>

static volatile int counter;   /* volatile: one load and one store per increment, not one add */
static pthread_barrier_t start, stop;

static void *bump(void *arg)
{
    pthread_barrier_wait(&start);
    for (int i = 0; i < 100000; ++i) counter = counter + 1;
    pthread_barrier_wait(&stop);
    return arg;
}

int main(void)
{
    pthread_t a, b;
    pthread_barrier_init(&start, NULL, 2);
    pthread_barrier_init(&stop, NULL, 2);
    pthread_create(&a, NULL, bump, NULL);
    pthread_create(&b, NULL, bump, NULL);
    pthread_join(a, NULL);
    pthread_join(b, NULL);
    printf("%d\n", counter);
    return 0;
}
