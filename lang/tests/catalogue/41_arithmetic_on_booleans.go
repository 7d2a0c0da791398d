// Arithmetic needs numbers; `&&` needs booleans; `==` needs the same type.
package BoolMath

var D1 Quadcopter

func INIT() {
	WaitUntil(D1.IsArmed()+1 > 1, SEQ_Go)
	WaitUntil(D1.X() && D1.IsArmed(), SEQ_Go)
	WaitUntil(D1.IsArmed() == 1, SEQ_Go)
}

func SEQ_Go() {
	D1.Takeoff(1)
}
