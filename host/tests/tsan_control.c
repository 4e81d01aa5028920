/* tsan_control — a deliberate data race (two threads increment one int without a lock), for
 * tests/test_host_packaging.py: ThreadSanitizer must report it, or its clean report of
 * host_threads means nothing. */
#include <pthread.h>
#include <stdio.h>

static int counter;

static void *bump(void *arg)
{
    for (int i = 0; i < 100000; ++i) counter++;
    return arg;
}

int main(void)
{
    pthread_t a, b;
    pthread_create(&a, NULL, bump, NULL);
    pthread_create(&b, NULL, bump, NULL);
    pthread_join(a, NULL);
    pthread_join(b, NULL);
    printf("%d\n", counter);
    return 0;
}
