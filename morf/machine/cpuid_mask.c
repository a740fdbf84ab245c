/* Make this process (and every process it starts) see a smaller x86 CPU through CPUID.

   Loaded with LD_PRELOAD by `morf bench --cpu-as CLASS ...` (morf/machine/cpuid_mask.py). Linux
   can make the CPUID instruction fault (arch_prctl ARCH_SET_CPUID, CPUs with "cpuid_fault"); the
   fault lands in a SIGSEGV handler here, which runs the real CPUID with faulting briefly off,
   clears the feature bits the chosen CPU class lacks and resumes after the instruction. Libraries
   that pick their kernels from CPUID (onnxruntime's MLAS, LLVM in numba and llvmpipe) then pick
   those of that class, on this silicon.

   MORF_CPUID_MASK selects the class:
     avx2         AVX2 + FMA, no AVX-512, no VNNI, no AMX (Haswell, AMD Zen 2 class)
     avx512-vnni  AVX-512 with VNNI, no AMX, no AVX-VNNI, no native bf16 / fp16 (Cascade / Ice Lake)

   The handler keeps its place when the program installs its own SIGSEGV handler (sigaction and
   signal are wrapped): faults that are not CPUID go to the program's handler, or kill the
   process as they would have. */
#define _GNU_SOURCE
#include <asm/prctl.h>
#include <cpuid.h>
#include <dlfcn.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/syscall.h>
#include <ucontext.h>
#include <unistd.h>

#ifndef ARCH_SET_CPUID
#define ARCH_SET_CPUID 0x1012
#endif

/* Read by morf/machine/cpuid_mask.py: 0 = not masking, 1 = avx2, 2 = avx512-vnni;
   morf_cpuid_mask_faults counts the CPUID instructions answered. */
int morf_cpuid_mask_level = 0;
volatile unsigned long morf_cpuid_mask_faults = 0;

static struct sigaction app_action; /* what the program asked for SIGSEGV */
static int app_action_set = 0;

typedef int (*sigaction_fn)(int, const struct sigaction *, struct sigaction *);
static sigaction_fn real_sigaction_ptr = 0;

static int real_sigaction(int sig, const struct sigaction *act, struct sigaction *old) {
    if (!real_sigaction_ptr) real_sigaction_ptr = (sigaction_fn)dlsym(RTLD_NEXT, "sigaction");
    return real_sigaction_ptr(sig, act, old);
}

#define BIT(n) (1u << (n))

static void mask_leaf(unsigned leaf, unsigned sub, unsigned r[4]) {
    /* r: eax, ebx, ecx, edx */
    const int level = morf_cpuid_mask_level;
    if (leaf == 7 && sub == 0) {
        /* edx: AMX-BF16 22, AVX512-FP16 23, AMX-TILE 24, AMX-INT8 25 */
        r[3] &= ~(BIT(22) | BIT(23) | BIT(24) | BIT(25));
        if (level == 1) {
            /* ebx: AVX512 F 16, DQ 17, IFMA 21, PF 26, ER 27, CD 28, BW 30, VL 31 */
            r[1] &= ~(BIT(16) | BIT(17) | BIT(21) | BIT(26) | BIT(27) | BIT(28) | BIT(30) | BIT(31));
            /* ecx: VBMI 1, VBMI2 6, GFNI 8, VAES 9, VPCLMULQDQ 10, VNNI 11, BITALG 12, VPOPCNTDQ 14 */
            r[2] &= ~(BIT(1) | BIT(6) | BIT(8) | BIT(9) | BIT(10) | BIT(11) | BIT(12) | BIT(14));
            /* edx: 4VNNIW 2, 4FMAPS 3, VP2INTERSECT 8 */
            r[3] &= ~(BIT(2) | BIT(3) | BIT(8));
        }
    } else if (leaf == 7 && sub == 1) {
        /* eax: AVX-VNNI 4, AVX512-BF16 5, AMX-FP16 21, AVX-IFMA 23;
           edx: AVX-VNNI-INT8 4, AVX-NE-CONVERT 5, AVX-VNNI-INT16 10, AVX10 19 */
        r[0] &= ~(BIT(4) | BIT(5) | BIT(21) | BIT(23));
        r[3] &= ~(BIT(4) | BIT(5) | BIT(10) | BIT(19));
    } else if (leaf == 0xD && sub == 0) {
        /* the state components the OS may enable: AMX tile config 17 and data 18; AVX-512 5-7 */
        r[0] &= ~(BIT(17) | BIT(18));
        if (level == 1) r[0] &= ~(BIT(5) | BIT(6) | BIT(7));
    } else if (leaf == 0x1D || leaf == 0x1E || leaf == 0x24) {
        r[0] = r[1] = r[2] = r[3] = 0; /* AMX tile and AVX10 information */
    }
}

static void on_segv(int sig, siginfo_t *info, void *ctx) {
    ucontext_t *uc = (ucontext_t *)ctx;
    greg_t *g = uc->uc_mcontext.gregs;
    const unsigned char *ip = (const unsigned char *)g[REG_RIP];
    if (info->si_code == SI_KERNEL && ip[0] == 0x0F && ip[1] == 0xA2) {
        unsigned r[4];
        const unsigned leaf = (unsigned)g[REG_RAX], sub = (unsigned)g[REG_RCX];
        syscall(SYS_arch_prctl, ARCH_SET_CPUID, 1);
        __cpuid_count(leaf, sub, r[0], r[1], r[2], r[3]);
        syscall(SYS_arch_prctl, ARCH_SET_CPUID, 0);
        mask_leaf(leaf, sub, r);
        g[REG_RAX] = r[0];
        g[REG_RBX] = r[1];
        g[REG_RCX] = r[2];
        g[REG_RDX] = r[3];
        g[REG_RIP] += 2;
        morf_cpuid_mask_faults++;
        return;
    }
    /* not ours: the program's handler, or the default action once the fault repeats */
    if (app_action_set && (app_action.sa_flags & SA_SIGINFO) && app_action.sa_sigaction) {
        app_action.sa_sigaction(sig, info, ctx);
        return;
    }
    if (app_action_set && app_action.sa_handler != SIG_DFL && app_action.sa_handler != SIG_IGN) {
        app_action.sa_handler(sig);
        return;
    }
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    real_sigaction(SIGSEGV, &dfl, 0);
}

static int install_handler(void) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_sigaction = on_segv;
    sa.sa_flags = SA_SIGINFO | SA_NODEFER;
    sigemptyset(&sa.sa_mask);
    return real_sigaction(SIGSEGV, &sa, 0);
}

int sigaction(int sig, const struct sigaction *act, struct sigaction *old) {
    if (sig != SIGSEGV || !morf_cpuid_mask_level) return real_sigaction(sig, act, old);
    if (old) {
        if (app_action_set) *old = app_action;
        else {
            memset(old, 0, sizeof *old);
            old->sa_handler = SIG_DFL;
        }
    }
    if (act) {
        app_action = *act;
        app_action_set = 1;
    }
    return 0;
}

sighandler_t signal(int sig, sighandler_t handler) {
    if (sig != SIGSEGV || !morf_cpuid_mask_level) {
        struct sigaction sa, old;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = handler;
        sa.sa_flags = SA_RESTART;
        sigemptyset(&sa.sa_mask);
        if (real_sigaction(sig, &sa, &old) != 0) return SIG_ERR;
        return old.sa_handler;
    }
    sighandler_t previous = app_action_set ? app_action.sa_handler : SIG_DFL;
    memset(&app_action, 0, sizeof app_action);
    app_action.sa_handler = handler;
    app_action_set = 1;
    return previous;
}

__attribute__((constructor)) static void start_masking(void) {
    const char *level = getenv("MORF_CPUID_MASK");
    if (!level) return;
    int wanted = !strcmp(level, "avx2") ? 1 : (!strcmp(level, "avx512-vnni") ? 2 : 0);
    if (!wanted) return;
    morf_cpuid_mask_level = wanted;
    if (install_handler() != 0 || syscall(SYS_arch_prctl, ARCH_SET_CPUID, 0) != 0)
        morf_cpuid_mask_level = 0; /* no CPUID faulting here: the Python side reports it */
}
